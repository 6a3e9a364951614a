"""The robot interface, in LeRobot's conventions: ``connect`` / ``disconnect`` / ``get_observation`` /
``send_action``, flat keys with ``left_`` / ``right_`` prefixes, a calibration state.

Observation keys (per arm ``{arm}_``, per camera ``{cam}_``):
    {arm}_ee_pose (7,) x, y, z, qx, qy, qz, qw in the world frame; {arm}_gripper_open (1 open, 0 closed)
    {cam}_rgb uint8 (H, W, 3); {cam}_depth float32 (H, W) metres
    {cam}_intrinsics (3, 3), {cam}_extrinsics (4, 4) camera-to-world: optional, a robot that knows them per
        frame (a simulator, a driver composing a wrist camera's hand-eye transform) sends them; otherwise the
        calibration's are used
    {cam}_instance, {cam}_class int (H, W): optional (a simulator's segmentation)
Action keys: {arm}_ee_pose (7,), {arm}_gripper_open, {arm}_ignore_collisions. ``send_action`` returns the
command actually sent, after the safety limits.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bimanualshift.data.frames import KeyframeObservation, SceneInfo
from bimanualshift.utils.config_files import read_json_file
from bimanualshift.utils.io import atomic_write_json


@dataclass
class Calibration:
    """Where the cameras and arm bases are in the world frame: what `bimanualshift calibrate` writes."""

    intrinsics: dict[str, list[list[float]]] = field(default_factory=dict)  # per camera (3, 3)
    extrinsics: dict[str, list[list[float]]] = field(default_factory=dict)  # per static camera, camera-to-world
    hand_eye: dict[str, dict[str, Any]] = field(default_factory=dict)  # per wrist camera: {"arm", camera-to-gripper}
    arm_bases: dict[str, list[float]] = field(default_factory=dict)  # per arm, base position in the world (m)
    source: str = ""  # how it was obtained (a solver and its residuals, or the simulator's truth)

    def save(self, path: str | Path) -> Path:
        atomic_write_json(path, {"format": "bimanualshift-calibration", "version": 1, **self.__dict__})
        return Path(path)

    @staticmethod
    def load(path: str | Path) -> Calibration:
        raw = read_json_file(Path(path), "calibration file")
        if raw.get("format") != "bimanualshift-calibration":
            raise ValueError(f"{path} is not a calibration file (written by `bimanualshift calibrate`)")
        return Calibration(raw.get("intrinsics", {}), raw.get("extrinsics", {}), raw.get("hand_eye", {}),
                           raw.get("arm_bases", {}), raw.get("source", ""))

    def camera_to_world(self, camera: str, ee_poses: dict[str, np.ndarray]) -> np.ndarray:
        """A static camera's extrinsics, or a wrist camera's from its arm's current pose and its hand-eye."""
        if camera in self.extrinsics:
            return np.asarray(self.extrinsics[camera], np.float64)
        if camera in self.hand_eye:
            link = self.hand_eye[camera]
            return pose_matrix(ee_poses[link["arm"]]) @ np.asarray(link["camera_to_gripper"], np.float64)
        raise ValueError(f"camera {camera!r} is not in the calibration (it has {sorted(self.extrinsics)} static "
                         f"and {sorted(self.hand_eye)} wrist cameras): run `bimanualshift calibrate` for it")


def pose_matrix(pose: np.ndarray) -> np.ndarray:
    """(7,) x, y, z, qx, qy, qz, qw -> 4x4."""
    from scipy.spatial.transform import Rotation

    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat(np.asarray(pose[3:7], np.float64)).as_matrix()
    m[:3, 3] = pose[:3]
    return m


class Robot(ABC):
    """A dual-arm robot with RGB-D cameras. Real drivers (UR over RTDE, Franka, a ROS 2 bridge) fill the same
    methods; ``sim_robot.MujocoRobot`` fills them on the benchmark scene."""

    arm_names: tuple[str, ...]
    camera_names: tuple[str, ...]
    calibration: Calibration | None = None

    @property
    @abstractmethod
    def is_connected(self) -> bool: ...

    @property
    def is_calibrated(self) -> bool:
        return self.calibration is not None

    @abstractmethod
    def connect(self) -> None: ...

    @abstractmethod
    def disconnect(self) -> None: ...

    @abstractmethod
    def get_observation(self) -> dict[str, Any]: ...

    @abstractmethod
    def send_action(self, action: dict[str, Any]) -> dict[str, Any]: ...

    @abstractmethod
    def hold(self) -> None:
        """Keep every arm where it is (the server went away, or an operator stopped the episode)."""


def action_dict(rows: np.ndarray, arm_names: list[str] | tuple[str, ...]) -> dict[str, Any]:
    """(arms, 9) world rows as robot action keys."""
    out: dict[str, Any] = {}
    for a, arm in enumerate(arm_names):
        out[f"{arm}_ee_pose"] = np.asarray(rows[a, :7], np.float64)
        out[f"{arm}_gripper_open"] = float(rows[a, 7])
        out[f"{arm}_ignore_collisions"] = float(rows[a, 8])
    return out


def action_rows(action: dict[str, Any], arm_names: list[str] | tuple[str, ...]) -> np.ndarray:
    return np.asarray([np.r_[action[f"{arm}_ee_pose"], action[f"{arm}_gripper_open"],
                             action.get(f"{arm}_ignore_collisions", 0.0)] for arm in arm_names], np.float32)


@dataclass
class EpisodeContext:
    """What a message needs beyond the robot's readings: the instruction, the episode id, the segmentation's
    names (a simulator's) and the goal nouns (when the task knows better than the instruction's parse)."""

    instruction: str
    episode_id: str
    goal_nouns: list[str] | None = None
    instance_names: list[str] | None = None
    class_names: list[str] | None = None
    instance_colours: dict[str, list[str]] | None = None  # a simulator's painted colours per instance


def observation_from_robot(robot: Robot, reading: dict[str, Any], context: EpisodeContext,
                           keyframe: int) -> KeyframeObservation:
    """A robot's reading, completed by its calibration, as the policy's observation."""
    calibration = robot.calibration
    if calibration is None:
        raise ValueError("the robot is not calibrated: run `bimanualshift calibrate` and pass --calibration FILE")
    arms = list(robot.arm_names)
    ee = {arm: np.asarray(reading[f"{arm}_ee_pose"], np.float64) for arm in arms}
    cams = list(robot.camera_names)
    intr = [np.asarray(reading[f"{c}_intrinsics"]) if f"{c}_intrinsics" in reading
            else np.asarray(calibration.intrinsics[c], np.float64) for c in cams]
    extr = [np.asarray(reading[f"{c}_extrinsics"]) if f"{c}_extrinsics" in reading
            else calibration.camera_to_world(c, ee) for c in cams]
    maps = all(f"{c}_instance" in reading for c in cams)
    rgb = np.stack([reading[f"{c}_rgb"] for c in cams])
    zeros = np.zeros(rgb.shape[:3], np.int16)
    proprio = np.stack([np.r_[np.asarray(reading[f"{arm}_ee_pose"]), reading[f"{arm}_gripper_open"]]
                        for arm in arms]).astype(np.float32)
    scene = SceneInfo(cams, arms, context.instance_names or [], context.class_names or [],
                      context.goal_nouns or [], {arm: list(calibration.arm_bases[arm]) for arm in arms},
                      dict(context.instance_colours or {}))
    return KeyframeObservation(
        rgb, np.stack([reading[f"{c}_depth"] for c in cams]),
        np.stack([reading[f"{c}_instance"] for c in cams]) if maps else zeros,
        np.stack([reading[f"{c}_class"] for c in cams]) if maps else zeros,
        np.stack(intr), np.stack(extr), proprio, context.instruction, keyframe, scene)

