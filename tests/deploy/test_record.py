"""Teleoperated recording on the simulated robot: the scripted expert as the leader device gives a successful
episode in the project's format, keyframes found by the discovery, dense trajectory kept; the keyboard device
moves the selected arm."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bimanualshift.data.episode import read_episode
from bimanualshift.deploy.record import record
from bimanualshift.deploy.sim_robot import MujocoRobot
from bimanualshift.deploy.teleop import KeyboardTeleop, ScriptedTeleop
from bimanualshift.sim.keyframes import discover_keyframes
from bimanualshift.sim.task_registry import task_class, task_names

from suite_tasks import SLOW_PHYSICS

pytestmark = pytest.mark.slow


def test_scripted_teleop_records_a_trainable_episode(tmp_path: Path) -> None:
    [path] = record("push_two_buttons", ScriptedTeleop(), [0], tmp_path)
    episode = read_episode(path)  # the format's own validation
    assert episode.success and episode.dense is not None
    keyframes = discover_keyframes(episode.dense["gripper_open"], episode.dense["joint_velocities"],
                                   hand_positions=episode.dense["eef_pose"])
    assert episode.num_keyframes == len(keyframes) >= 2
    # each action is the dense pose at its keyframe; the first observation is the scene before any motion
    assert np.allclose(episode.arrays["actions"][:, :, :7], episode.dense["eef_pose"][keyframes], atol=1e-6)
    assert np.allclose(episode.arrays["proprio"][0, :, :3], episode.dense["eef_pose"][0, :, :3], atol=1e-5)
    assert episode.arrays["rgb"].shape[:2] == (len(keyframes), len(episode.camera_names))


def test_keyboard_teleop_moves_the_selected_arm() -> None:
    robot = MujocoRobot("push_two_buttons")
    robot.connect()
    try:
        robot.reset_episode(0)
        device = KeyboardTeleop(step_m=0.01, keys=iter(["w", "w", "\t", "f", "g"]))
        device.start(robot)
        start = robot.joint_reading()
        commands = [device.command(start) for _ in range(5)]
        assert device.command(start) is None  # the keys ran out: q
        last = commands[-1]
        assert np.allclose(last["left"][0] - start["left_ee_pose"][:3], [0.02, 0, 0])
        assert np.allclose(last["right"][0] - start["right_ee_pose"][:3], [0, 0, -0.01])
        assert last["right"][2] == 1.0 - start["right_gripper_open"] and last["left"][2] == start["left_gripper_open"]
    finally:
        robot.disconnect()


# A cloth, a cable or 40 balls make a teleoperated episode 10-15 s (SLOW_PHYSICS); their experts' keyframe counts are
# checked against the table in tests/sim/test_tasks.py, and the discovery below on the twin's rigid-object tasks.
@pytest.mark.parametrize("task", [t for t in task_names(robot="ur5e")
                                  if task_class(t).paper_keyframes and t not in SLOW_PHYSICS])
def test_a_teleoperated_twin_demo_has_its_tables_keyframe_count(task: str, tmp_path: Path) -> None:
    # the scripted leader moves as a person would: on to the next pose without stopping, a pause at each key pose,
    # seconds-long stops where a push is blocked; discovery must give one keyframe per key pose all the same
    [path] = record(task, ScriptedTeleop(), [3], tmp_path)
    episode = read_episode(path)
    assert episode.success and abs(episode.num_keyframes - task_class(task).paper_keyframes) <= 1
