"""Rigid transforms, the arm-centric frame and rotation helpers.

Quaternions are (x, y, z, w) everywhere in this package (SciPy's convention). The arm-centric frame of
an arm has its origin at the arm's base and its x axis pointing from the base towards the table, so a
single-arm policy trained with its arm at the origin can serve either arm of a bimanual robot.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation


def make_transform(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = rotation
    out[:3, 3] = translation
    return out


def transform_points(transform: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 4x4 transform to points of shape (..., 3)."""
    return points @ transform[:3, :3].T.astype(points.dtype) + transform[:3, 3].astype(points.dtype)


@dataclass(frozen=True)
class ArmFrame:
    """Pose of an arm's base in the world: position (3,) and yaw about world z (radians)."""

    position: tuple[float, float, float]
    yaw: float = 0.0

    @property
    def base_to_world(self) -> np.ndarray:
        return make_transform(Rotation.from_euler("z", self.yaw).as_matrix(), np.asarray(self.position))

    @property
    def world_to_base(self) -> np.ndarray:
        return np.linalg.inv(self.base_to_world)

    def points_to_arm(self, points: np.ndarray) -> np.ndarray:
        return transform_points(self.world_to_base, points)

    def points_to_world(self, points: np.ndarray) -> np.ndarray:
        return transform_points(self.base_to_world, points)

    def pose_to_arm(self, position: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rot = Rotation.from_euler("z", -self.yaw) * Rotation.from_quat(quat)
        return self.points_to_arm(np.asarray(position, dtype=np.float64)), canonical_quat(rot.as_quat())

    def pose_to_world(self, position: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rot = Rotation.from_euler("z", self.yaw) * Rotation.from_quat(quat)
        return self.points_to_world(np.asarray(position, dtype=np.float64)), canonical_quat(rot.as_quat())


def canonical_quat(quat: np.ndarray) -> np.ndarray:
    """Unit quaternion with w >= 0 (q and -q are the same rotation)."""
    q = np.asarray(quat, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., 3:4] < 0, -q, q)


# The gripper pointing straight down in an arm's frame (x y z w): a half turn about x, where w is 0. The benchmark's
# keyframes lie within a quarter turn of it, so the w >= 0 sign flips at random there (half the demos' poses).
GRIPPER_DOWN_QUAT = np.array([1.0, 0.0, 0.0, 0.0])


def quat_toward(quat: np.ndarray, pole: np.ndarray = GRIPPER_DOWN_QUAT) -> np.ndarray:
    """q or -q (each row of ``quat``), whichever lies on ``pole``'s side (dot >= 0): a sign that changes only half
    a turn away from ``pole``, where w >= 0 changes wherever w crosses 0."""
    q = np.asarray(quat, dtype=np.float64)
    return np.where((q @ np.asarray(pole, np.float64))[..., None] < 0, -q, q)


def rotation_angle(a: np.ndarray, b: np.ndarray) -> float:
    """The angle (rad) of the rotation between two unit quaternions (components in the same order in both)."""
    w = abs(float(np.dot(a, b)))
    return 2.0 * float(np.arctan2(np.sqrt(max(0.0, 1.0 - w * w)), w))


def slerp(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    """The unit quaternion a fraction ``t`` of the way from ``a`` to ``b`` along the shorter rotation."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    dot = float(np.dot(a, b))
    if dot < 0.0:
        b, dot = -b, -dot
    if dot > 0.9995:  # nearly the same rotation: linear interpolation is exact to rounding
        q = a + t * (b - a)
        return q / np.linalg.norm(q)
    theta = np.arccos(dot) * t
    ortho = b - a * dot
    return a * np.cos(theta) + ortho / np.linalg.norm(ortho) * np.sin(theta)


def quat_to_euler_bins(quat: np.ndarray, bin_degrees: float) -> np.ndarray:
    """Discretise a rotation into per-axis bins of its xyz Euler angles (PerAct's rotation output)."""
    euler = Rotation.from_quat(quat).as_euler("xyz", degrees=True)  # each in (-180, 180]
    n_bins = int(round(360 / bin_degrees))
    return np.clip(np.floor((euler + 180.0) / bin_degrees).astype(np.int64), 0, n_bins - 1)


def euler_bins_to_quat(bins: np.ndarray, bin_degrees: float) -> np.ndarray:
    euler = np.asarray(bins, dtype=np.float64) * bin_degrees - 180.0 + bin_degrees / 2
    return canonical_quat(Rotation.from_euler("xyz", euler, degrees=True).as_quat())


def compose_rotation(quat: np.ndarray, rotvec: np.ndarray) -> np.ndarray:
    """Apply a residual rotation (axis-angle, world-aligned) on SO(3): R = exp(rotvec) * R_base."""
    return canonical_quat((Rotation.from_rotvec(rotvec) * Rotation.from_quat(quat)).as_quat())


def gripper_angle_deg(quat_a: np.ndarray, quat_b: np.ndarray) -> float:
    """Degrees between two gripper orientations ((x, y, z, w) quaternions), a half turn about the approach axis
    (the gripper's own z) counting as none: a parallel gripper's two fingers are alike."""
    a, b = Rotation.from_quat(quat_a), Rotation.from_quat(quat_b)
    flipped = b * Rotation.from_euler("z", np.pi)
    return float(np.degrees(min((a.inv() * b).magnitude(), (a.inv() * flipped).magnitude())))


def nearest_grasp_twin(quat_target: np.ndarray, quat_base: np.ndarray) -> np.ndarray:
    """``quat_target`` or its twin half a turn about the gripper's own approach axis (local z), whichever is nearer
    ``quat_base``. A parallel gripper closes the same way in both, so the twin is the same grasp; a target whose
    twin lies nearer the prior's proposal asks the residual for the smaller turn. The demos' wrist yaw is wrapped
    into a half turn, so a grasp near the wrap's edge (sweep's dustpan handle) comes as either twin at random."""
    target = Rotation.from_quat(quat_target)
    twin = target * Rotation.from_euler("z", np.pi)
    base = Rotation.from_quat(quat_base)
    nearer = (base.inv() * twin).magnitude() < (base.inv() * target).magnitude()
    return twin.as_quat() if nearer else np.asarray(quat_target, dtype=np.float64)


def grasp_twin_mean(quats: np.ndarray, rounds: int = 5) -> np.ndarray:
    """The mean orientation of grasps given as either half-turn twin (``nearest_grasp_twin``): each is taken as the
    twin nearer the running mean, starting from the first, and the mean of those is taken again. A set of grasps
    clustered about one heading, however the demos wrapped each, gives that heading (as one of its twins)."""
    quats = np.asarray(quats, dtype=np.float64).reshape(-1, 4)
    mean = quats[0]
    for _ in range(rounds):
        mean = Rotation.from_quat(np.stack([nearest_grasp_twin(q, mean) for q in quats])).mean().as_quat()
    return mean


def rotation_difference(quat_target: np.ndarray, quat_base: np.ndarray) -> np.ndarray:
    """Axis-angle r with exp(r) * R_base = R_target (inverse of ``compose_rotation``)."""
    return (Rotation.from_quat(quat_target) * Rotation.from_quat(quat_base).inv()).as_rotvec()
