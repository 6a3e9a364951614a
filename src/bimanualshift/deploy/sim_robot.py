"""The robot interface on the benchmark's MuJoCo scene, so the whole deployment loop runs on one machine.

A command is one keyframe: the scene's motion executor (robosuite's OSC) moves both arms to it, as in the
benchmark. The calibration is the simulator's truth (``truth_calibration``), or a file `bimanualshift
calibrate` solved from rendered marker views.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bimanualshift.deploy.robot import Calibration, EpisodeContext, Robot, action_rows
from bimanualshift.deploy.safety import SafetyFilter, SafetyLimits
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.layout import WORKSPACE_HIGH, WORKSPACE_LOW

# What the simulated arms accept: the benchmark's workspace, 0.5 mm inside its walls. A command clipped onto a wall
# would leave it once sent as float32 and be refused; the policies' own actions stay 1 mm inside (``world_action``),
# so they pass unclipped. A keyframe may cross the table in one command (the executor plans the motion), so the step
# limits only catch nonsense.
SIM_LIMITS = SafetyLimits(tuple(WORKSPACE_LOW + 5e-4), tuple(WORKSPACE_HIGH - 5e-4), max_translation_m=1.5,
                          max_rotation_rad=np.pi)


class MujocoRobot(Robot):
    def __init__(self, task: str, limits: SafetyLimits = SIM_LIMITS, calibration: Calibration | None = None,
                 image_size: int | None = None) -> None:
        self.task_name, self.limits, self.image_size = task, limits, image_size
        self.env: ManipulationEnv | None = None
        # a calibration file replaces the simulator's static camera poses and base anchors (its wrist cameras keep
        # the simulator's: the file holds no hand-eye transform for them)
        self.calibration = calibration
        self.calibrated_from_file = calibration is not None
        self._obs: dict[str, Any] | None = None
        self.filters: dict[str, SafetyFilter] = {}
        self.success, self.stages_done, self.held = False, 0, False

    # -- connection ---------------------------------------------------------------------------------------------
    @property
    def is_connected(self) -> bool:
        return self.env is not None

    def connect(self) -> None:
        if self.env is None:
            self.env = ManipulationEnv(self.task_name, image_size=self.image_size)
            self.arm_names = tuple(self.env.arm_names)
            self.camera_names = tuple(self.env.camera_names)

    def disconnect(self) -> None:
        if self.env is not None:
            self.env.close()
            self.env = None

    def _env(self) -> ManipulationEnv:
        if self.env is None:
            raise RuntimeError("the robot is not connected: call connect() first")
        return self.env

    # -- episodes (a simulator's own: a real robot's scene is set by hand) ---------------------------------------
    def reset_episode(self, seed: int) -> EpisodeContext:
        env = self._env()
        self._obs, _ = env.reset(seed=seed)
        if self.calibration is None:
            self.calibration = truth_calibration(env, self._obs)
        self.success, self.stages_done = False, 0
        self.filters = {arm: SafetyFilter(self.limits) for arm in self.arm_names}
        for a, arm in enumerate(self.arm_names):
            self.filters[arm].start(self._obs["proprio"][a, :7], float(self._obs["proprio"][a, 7]))
        return EpisodeContext(env.task.instruction(), f"{self.task_name}-{seed}", env.task.goal_nouns(),
                              env.instances.names, env.instances.classes, env.instance_colours())

    def expert_keyframe_count(self) -> int:
        return len(self._env().expert_keyframes())

    # -- readings and commands -----------------------------------------------------------------------------------
    def get_observation(self) -> dict[str, Any]:
        if self._obs is None:
            raise RuntimeError("no episode: call reset_episode(seed) first")
        obs, out = self._obs, {}
        for a, arm in enumerate(self.arm_names):
            out[f"{arm}_ee_pose"] = obs["proprio"][a, :7].copy()
            out[f"{arm}_gripper_open"] = float(obs["proprio"][a, 7])
        for cam in self.camera_names:
            views = obs["cameras"][cam]
            out[f"{cam}_rgb"], out[f"{cam}_depth"] = views["rgb"], views["depth"]
            out[f"{cam}_instance"], out[f"{cam}_class"] = views["instance"], views["class"]
            if not (self.calibrated_from_file and cam in self.calibration.extrinsics):
                out[f"{cam}_intrinsics"], out[f"{cam}_extrinsics"] = obs["intrinsics"][cam], obs["extrinsics"][cam]
        return out

    def joint_reading(self) -> dict[str, Any]:
        """The arms' poses and grippers now, without rendering (what a teleoperator reads every control step)."""
        env = self._env()
        proprio = env.proprio()
        return {**{f"{arm}_ee_pose": proprio[a, :7] for a, arm in enumerate(self.arm_names)},
                **{f"{arm}_gripper_open": float(proprio[a, 7]) for a, arm in enumerate(self.arm_names)}}

    def servo(self, command: dict[str, tuple[np.ndarray, np.ndarray, float]]) -> None:
        """One control step towards a teleoperator's targets, clipped into the workspace."""
        low, high = np.asarray(self.limits.workspace_low), np.asarray(self.limits.workspace_high)
        self._env().servo({arm: np.clip(c[0], low, high) for arm, c in command.items()},
                          {arm: c[1] for arm, c in command.items()}, {arm: c[2] for arm, c in command.items()})

    def hold(self) -> None:
        # the arms' controllers keep their last targets; nothing more is stepped until the next command
        self.held = True

    def send_action(self, action: dict[str, Any]) -> dict[str, Any]:
        env = self._env()
        self.held = False
        sent: dict[str, Any] = {}
        for arm in self.arm_names:
            pose, grip, clipped = self.filters[arm].apply(np.asarray(action[f"{arm}_ee_pose"]),
                                                          float(action[f"{arm}_gripper_open"]))
            # an unclipped command goes on bit for bit (the float64 round trip of a float32 row is exact)
            sent[f"{arm}_ee_pose"] = action[f"{arm}_ee_pose"] if not clipped else pose
            sent[f"{arm}_gripper_open"] = action[f"{arm}_gripper_open"] if not clipped else grip
            sent[f"{arm}_ignore_collisions"] = float(action.get(f"{arm}_ignore_collisions", 0.0))
            sent[f"{arm}_clipped"] = clipped
        self._obs, _, success, truncated, info = env.step(action_rows(sent, self.arm_names))
        self.success, self.stages_done = bool(success), int(info["stages_done"])
        sent["truncated"] = bool(truncated)
        return sent


def truth_calibration(env: ManipulationEnv, obs: dict[str, Any]) -> Calibration:
    """The simulator's own camera and base poses (what a perfect calibration would give)."""
    wrist = set(env.cameras.wrist_cameras) if hasattr(env.cameras, "wrist_cameras") else set()
    return Calibration(
        intrinsics={c: np.asarray(obs["intrinsics"][c]).tolist() for c in env.camera_names},
        extrinsics={c: np.asarray(obs["extrinsics"][c]).tolist() for c in env.camera_names if c not in wrist},
        arm_bases={arm: [float(v) for v in f.position] for arm, f in env.arm_frames.items()},
        source="simulator truth")


def first_observation_message(task: str, seed: int, episode_id: str) -> dict[str, Any]:
    """A real observation message: the task's scene on ``seed`` as the simulated robot sends it (benchmarks and
    fuzzing use it as the valid request)."""
    from bimanualshift.data.frames import KeyframeObservation, scene_of_env
    from bimanualshift.deploy.schema import observation_message

    env = ManipulationEnv(task)
    try:
        obs, _ = env.reset(seed=seed)
        return observation_message(KeyframeObservation.from_env(obs, scene_of_env(env)), episode_id)
    finally:
        env.close()
