"""Keyframes (or a chunk of them) as a stream of pose commands at the robot's rate, for drivers that servo
(UR ``servoL`` at 125 Hz, Franka's Cartesian generator): straight lines and slerp at bounded speeds.

The simulated robot does not need it: its scene's controller executes a keyframe itself, as the benchmark does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation, Slerp


@dataclass
class KeyframeExecutor:
    rate_hz: float = 125.0
    max_speed_m_s: float = 0.25
    max_angular_speed_rad_s: float = 1.0

    def __post_init__(self) -> None:
        if self.rate_hz <= 0 or self.max_speed_m_s <= 0 or self.max_angular_speed_rad_s <= 0:
            raise ValueError("rate_hz, max_speed_m_s and max_angular_speed_rad_s must be > 0")

    def waypoints(self, start: np.ndarray, target: np.ndarray) -> np.ndarray:
        """(n, 7) poses from ``start`` (excluded) to ``target`` (included), one per control period, so that
        neither speed limit is exceeded."""
        start, target = np.asarray(start, np.float64), np.asarray(target, np.float64)
        dist = float(np.linalg.norm(target[:3] - start[:3]))
        r0, r1 = Rotation.from_quat(start[3:7]), Rotation.from_quat(target[3:7])
        angle = float((r0.inv() * r1).magnitude())
        period = 1.0 / self.rate_hz
        steps = max(1, int(np.ceil(max(dist / (self.max_speed_m_s * period),
                                       angle / (self.max_angular_speed_rad_s * period)) - 1e-9)))
        s = np.arange(1, steps + 1) / steps
        positions = start[:3] + s[:, None] * (target[:3] - start[:3])
        quats = Slerp([0.0, 1.0], Rotation.concatenate([r0, r1]))(s).as_quat()
        return np.concatenate([positions, quats], axis=1)

    def chunk_waypoints(self, start: np.ndarray, chunk: np.ndarray) -> np.ndarray:
        """A chunk of (k, 7) keyframes executed one after the other."""
        parts, here = [], np.asarray(start, np.float64)
        for pose in np.asarray(chunk, np.float64):
            parts.append(self.waypoints(here, pose))
            here = pose
        return np.concatenate(parts)
