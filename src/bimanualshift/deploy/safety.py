"""Limits every command passes through before it reaches an arm. An in-bounds command leaves unchanged."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation, Slerp


@dataclass
class SafetyLimits:
    workspace_low: tuple[float, float, float] = (-0.45, -0.6, 0.8)  # world metres; the benchmark's table
    workspace_high: tuple[float, float, float] = (0.45, 0.6, 1.4)
    max_translation_m: float = 0.25  # per command
    max_rotation_rad: float = 1.6  # per command
    # the gripper changes state only after this many consecutive commands ask for the new state (1: at once)
    gripper_debounce: int = 1

    def __post_init__(self) -> None:
        if not (np.asarray(self.workspace_low) < np.asarray(self.workspace_high)).all():
            raise ValueError(f"workspace_low {self.workspace_low} must be below workspace_high {self.workspace_high} "
                             "on every axis")
        if self.max_translation_m <= 0 or self.max_rotation_rad <= 0 or self.gripper_debounce < 1:
            raise ValueError("max_translation_m and max_rotation_rad must be > 0 and gripper_debounce >= 1")


@dataclass
class SafetyFilter:
    """Clips one arm's commands: into the workspace box, at most ``max_translation_m`` / ``max_rotation_rad``
    from the previous command (or the measured pose at the start), the gripper debounced. ``events`` lists what
    was clipped, per command."""

    limits: SafetyLimits
    _last: np.ndarray | None = None
    _gripper: float | None = None
    _pending: int = 0
    events: list[list[str]] = field(default_factory=list)

    def start(self, pose: np.ndarray, gripper_open: float) -> None:
        """Begin from the arm's measured pose (x, y, z, qx, qy, qz, qw) and gripper."""
        self._last = np.asarray(pose, np.float64).copy()
        self._gripper, self._pending, self.events = float(gripper_open), 0, []

    def apply(self, pose: np.ndarray, gripper_open: float) -> tuple[np.ndarray, float, list[str]]:
        """The command actually sent: (pose, gripper_open, what was clipped)."""
        lim, clipped = self.limits, []
        target = np.asarray(pose, np.float64).copy()
        if not np.isfinite(target).all() or not np.isfinite(gripper_open):
            clipped.append("non-finite command: held the last pose")
            target = self._last.copy() if self._last is not None else target
            gripper_open = self._gripper if self._gripper is not None else 0.0
        low, high = np.asarray(lim.workspace_low), np.asarray(lim.workspace_high)
        if ((target[:3] < low) | (target[:3] > high)).any():
            target[:3] = np.clip(target[:3], low, high)
            clipped.append("workspace")
        if self._last is not None:
            step = target[:3] - self._last[:3]
            dist = float(np.linalg.norm(step))
            if dist > lim.max_translation_m:
                target[:3] = self._last[:3] + step * (lim.max_translation_m / dist)
                clipped.append("translation step")
            r0, r1 = Rotation.from_quat(self._last[3:7]), Rotation.from_quat(target[3:7])
            angle = float((r0.inv() * r1).magnitude())
            if angle > lim.max_rotation_rad:
                slerp = Slerp([0.0, 1.0], Rotation.concatenate([r0, r1]))
                target[3:7] = slerp([lim.max_rotation_rad / angle]).as_quat()[0]
                clipped.append("rotation step")
        grip = float(gripper_open)
        if self._gripper is not None and (grip > 0.5) != (self._gripper > 0.5):
            self._pending += 1
            if self._pending < lim.gripper_debounce:
                grip = self._gripper
                clipped.append("gripper debounce")
            else:
                self._pending = 0
        else:
            self._pending = 0
        self._last, self._gripper = target.copy(), grip
        self.events.append(clipped)
        return target, grip, clipped
