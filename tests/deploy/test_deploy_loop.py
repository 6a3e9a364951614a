"""The deployment loop on the MuJoCo robot: the same actions as the offline rollout, seed for seed, and a
server that dies mid-episode leaves the robot holding and the episode reported."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import CountingPolicy

from bimanualshift.deploy.client import PolicyClient
from bimanualshift.deploy.loop import run_sim_episode
from bimanualshift.deploy.served_policy import load_served_policy
from bimanualshift.deploy.server import PolicyServer, ServerConfig
from bimanualshift.deploy.sim_robot import MujocoRobot
from bimanualshift.evaluation.viewer import EpisodeRecorder, read_recording
from bimanualshift.rollout.loop import rollout
from bimanualshift.sim.env import ManipulationEnv

pytestmark = pytest.mark.slow


def test_deployed_episode_matches_the_offline_rollout(tmp_path: Path) -> None:
    served = load_served_policy("no_residual", prior="peract_suite")
    env = ManipulationEnv("push_two_buttons")
    exact: list[list] = []

    def act(k: int, frame: object) -> np.ndarray:
        exact.append(served.policy.act(frame).tolist())
        return np.asarray(exact[-1], np.float32)

    served.policy.reset()
    offline = rollout(env, served.policy, seed=3, max_keyframes=2, act=act)
    env.close()
    server = PolicyServer(served.policy, served.metadata, ServerConfig(port=0), check=served.check)
    server.start_background()
    robot = MujocoRobot("push_two_buttons")
    robot.connect()
    try:
        recorder = EpisodeRecorder(tmp_path / "deployed.rrd", points_per_camera=100)
        deployed = run_sim_episode(robot, PolicyClient(f"ws://127.0.0.1:{server.port}"), seed=3, max_keyframes=2,
                                   observer=recorder)
        recorder.close()
    finally:
        robot.disconnect()
        server.stop()
    assert deployed.aborted is None and deployed.keyframes == offline.keyframes == 2
    assert deployed.executed == exact  # bit for bit: the codec and the schema change nothing
    assert deployed.success == offline.success and deployed.stages_done == offline.stages_done
    assert "arms" in deployed.diagnostics[0]
    # the deployed episode in the viewer: what the robot's cameras gave the policy, and the server's log
    seen = read_recording(tmp_path / "deployed.rrd")
    root = "/push_two_buttons/deployed/seed_3"
    assert seen["keyframes"] == [0, 1] and f"{root}/cameras/front/rgb" in seen["entities"]
    assert seen["points"][f"{root}/arms/left/prior"] == [1, 1]  # the proposal the server logged


def test_server_death_mid_episode_holds_and_reports() -> None:
    server = PolicyServer(CountingPolicy(), {}, ServerConfig(port=0)).start_background()

    class DyingClient(PolicyClient):
        calls = 0

        def infer(self, message: dict) -> dict:
            self.calls += 1
            if self.calls == 2:
                server.stop()
            return super().infer(message)

    robot = MujocoRobot("push_two_buttons")
    robot.connect()
    try:
        record = run_sim_episode(robot, DyingClient(f"ws://127.0.0.1:{server.port}", retries=0), seed=0)
        assert record.keyframes == 1 and record.aborted and "ServerUnavailable" in record.aborted
        assert robot.env.keyframe_index == 1  # nothing was sent after the server went away
    finally:
        robot.disconnect()


def test_a_calibration_file_gives_the_anchors_and_static_camera_poses() -> None:
    from bimanualshift.deploy.robot import Calibration, observation_from_robot

    robot = MujocoRobot("push_two_buttons")
    robot.connect()
    try:
        context = robot.reset_episode(0)
        truth = robot.calibration
        moved = np.asarray(truth.extrinsics["front"])
        moved[:3, 3] += 0.004
        robot.calibration = Calibration(truth.intrinsics, {"front": moved.tolist()}, {},
                                        {"left": [-0.56, 0.301, 0.912], "right": [-0.561, -0.3, 0.913]}, "a file")
        robot.calibrated_from_file = True
        obs = observation_from_robot(robot, robot.get_observation(), context, 0)
        assert obs.scene.arm_bases == {"left": [-0.56, 0.301, 0.912], "right": [-0.561, -0.3, 0.913]}
        front = obs.scene.camera_names.index("front")
        assert np.allclose(obs.extrinsics[front], moved)  # the file's pose, not the simulator's
        overhead = obs.scene.camera_names.index("overhead")  # not in the file: the simulator's own
        assert np.allclose(obs.extrinsics[overhead], truth.extrinsics["overhead"])
    finally:
        robot.disconnect()


class PlanningPolicy:
    """Plans three keyframes per call: stay, 1 cm up, then 60 cm up (through the workspace's ceiling)."""

    name = "planning"

    def reset(self) -> None:
        self.rows = np.zeros((2, 9), np.float32)

    def act(self, obs: object) -> np.ndarray:
        self.rows = np.zeros((len(obs.scene.arm_names), 9), np.float32)
        self.rows[:, :7], self.rows[:, 7] = obs.proprio[:, :7], 1.0
        return self.rows

    def action_chunk(self) -> np.ndarray:
        up, far = self.rows.copy(), self.rows.copy()
        up[:, 2] += 0.01
        far[:, 2] += 0.60
        return np.stack([self.rows, up, far], axis=1)


# (keyframes run per reply, episode cap, requests): one per keyframe; one chunk; a chunk cut by the cap, then one more
@pytest.mark.parametrize(("chunk_steps", "cap", "requests"), [(1, 3, 3), (3, 3, 1), (3, 4, 2)])
def test_a_planned_chunk_runs_through_the_safety_filter(chunk_steps: int, cap: int, requests: int) -> None:
    from bimanualshift.deploy.sim_robot import SIM_LIMITS

    server = PolicyServer(PlanningPolicy(), {}, ServerConfig(port=0)).start_background()
    robot = MujocoRobot("push_two_buttons")
    robot.connect()
    try:
        record = run_sim_episode(robot, PolicyClient(f"ws://127.0.0.1:{server.port}"), seed=0, max_keyframes=cap,
                                 chunk_steps=chunk_steps)
    finally:
        robot.disconnect()
        server.stop()
    assert record.aborted is None and record.keyframes == cap and len(record.round_trip_ms) == requests
    executed = np.asarray(record.executed)  # (keyframes, arms, 9) as sent after the filter
    if chunk_steps == 1:
        assert record.clipped == 0  # only each reply's first keyframe runs: the arms stay where they are
    else:
        assert np.allclose(executed[1, :, 2] - executed[0, :, 2], 0.01, atol=1e-6)  # the plan, unchanged
        assert np.allclose(executed[2, :, 2], SIM_LIMITS.workspace_high[2])  # the 60 cm rise, stopped at the ceiling
        assert record.clipped >= 2  # that keyframe, for both arms
