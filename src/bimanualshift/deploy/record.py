"""Recording demonstrations by teleoperation: a device streams targets at the control rate, the dense trajectory
is kept, keyframes are found by the discovery the experts' demos use (``sim.keyframes``), and the episode is
written in the project's format (``data.episode``), ready for `train`.

On the simulated robot the cameras are not rendered at every control step: the simulator's state is kept per
step, and the views at the discovered keyframes are rendered afterwards from those states (a real recorder keeps
its camera streams and picks the same frames).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from tqdm import tqdm

from bimanualshift.data.collect import episode_from_rollout
from bimanualshift.data.episode import Episode, episode_path, write_episode
from bimanualshift.deploy.sim_robot import MujocoRobot
from bimanualshift.deploy.teleop import Teleoperator
from bimanualshift.sim.keyframes import discover_keyframes


def record_episode(robot: MujocoRobot, device: Teleoperator, seed: int, max_steps: int = 3000) -> Episode:
    robot.reset_episode(seed)
    env = robot.env
    device.start(robot)
    env.start_dense_recording()
    states = [env.get_state()]
    for _ in range(max_steps):
        command = device.command(robot.joint_reading())
        if command is None:
            break
        robot.servo(command)
        states.append(env.get_state())
    dense = env.dense_trajectory()
    success = env.success()
    keyframes = discover_keyframes(dense["gripper_open"], dense["joint_velocities"],
                                   hand_positions=dense["eef_pose"])
    # observation k is what the cameras saw before keyframe k's action: at step 0, then at each earlier keyframe
    observed = [0, *keyframes[:-1]]
    observations, actions = [], []
    for k, (step, keyframe) in enumerate(zip(observed, keyframes)):
        env.set_state(states[step])
        env.keyframe_index = k
        observations.append(env.observe(render=True))
        actions.append(np.concatenate([dense["eef_pose"][keyframe], dense["gripper_open"][keyframe][:, None],
                                       np.zeros((len(env.arm_names), 1), np.float32)], axis=1))
    env.set_state(states[-1])
    return episode_from_rollout(env, seed, observations, actions, success, dense=dense)


def record(task: str, device: Teleoperator, seeds: list[int], out: str | Path, keep_failures: bool = False
           ) -> list[Path]:
    """Record one episode per seed; successful ones are written (``keep_failures``: every one)."""
    robot = MujocoRobot(task)
    robot.connect()
    written = []
    try:
        for seed in tqdm(seeds, desc=f"record {task}", unit="ep"):
            episode = record_episode(robot, device, seed)
            if episode.success or keep_failures:
                written.append(write_episode(episode_path(out, task, seed), episode))
    finally:
        robot.disconnect()
    return written
