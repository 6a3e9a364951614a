"""Teleoperators: leader devices that stream end-effector targets, one per control step.

A device answers ``command(reading)`` with each arm's target (position, quaternion x y z w, gripper open) or
None when the demonstration is over. GELLO-style leader arms fill the same method from their joint readings
(forward kinematics of the leader, scaled into the follower's workspace).
"""

from __future__ import annotations

import select
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

Command = dict[str, tuple[np.ndarray, np.ndarray, float]]  # arm -> (position, quat xyzw, gripper_open)


class Teleoperator(Protocol):
    def start(self, robot: Any) -> None: ...

    def command(self, reading: dict[str, Any]) -> Command | None: ...


@dataclass
class ScriptedTeleop:
    """The scripted expert as a leader device: it drives each arm to the expert's next keyframe at a bounded
    speed, switches grippers once there, and ends after the last keyframe."""

    max_step_m: float = 0.012  # per control step (0.24 m/s at 20 Hz)
    max_step_rad: float = 0.1
    settle_steps: int = 8  # after a gripper change
    arrive_m: float = 0.015  # the hand this close to the keyframe: on to the next (a person does not stop either)
    timeout_steps: int = 120  # per keyframe: move on even if the pose is not reached (a blocked push)
    # at a key pose reached without a gripper change, hold still this many steps (a person pauses there, which is
    # what keyframe discovery finds in a teleoperated demonstration); 0: straight on
    dwell_steps: int = 10

    def start(self, robot: Any) -> None:
        env = robot.env
        self.arms = list(env.arm_names)
        self.plan = [env.action_from_keyframe(kf) for kf in env.expert_keyframes()]
        self.index, self.steps, self.settle = 0, 0, 0
        self.commanded: dict[str, np.ndarray] | None = None

    def command(self, reading: dict[str, Any]) -> Command | None:
        if self.index >= len(self.plan):
            return None
        target = self.plan[self.index]
        if self.commanded is None:
            self.commanded = {arm: np.asarray(reading[f"{arm}_ee_pose"], np.float64) for arm in self.arms}
            self.grip = {arm: float(reading[f"{arm}_gripper_open"]) for arm in self.arms}
        out: Command = {}
        arrived = True
        for a, arm in enumerate(self.arms):
            cmd = self.commanded[arm]
            delta = target[a, :3] - cmd[:3]
            dist = float(np.linalg.norm(delta))
            cmd[:3] += delta if dist <= self.max_step_m else delta * self.max_step_m / dist
            r0, r1 = Rotation.from_quat(cmd[3:7]), Rotation.from_quat(target[a, 3:7])
            angle = float((r0.inv() * r1).magnitude())
            if angle > 1e-6:
                turn = Slerp([0, 1], Rotation.concatenate([r0, r1]))
                cmd[3:7] = turn([min(1.0, self.max_step_rad / angle)]).as_quat()[0]
            here = np.asarray(reading[f"{arm}_ee_pose"], np.float64)
            arrived &= bool(np.linalg.norm(here[:3] - target[a, :3]) < self.arrive_m and dist <= self.max_step_m)
            out[arm] = (cmd[:3].copy(), cmd[3:7].copy(), self.grip[arm])
        self.steps += 1
        if self.settle:
            self.settle -= 1
            if self.settle == 0:
                self.index, self.steps = self.index + 1, 0
        elif arrived or self.steps >= self.timeout_steps:
            changed = [arm for a, arm in enumerate(self.arms) if (target[a, 7] > 0.5) != (self.grip[arm] > 0.5)]
            for a, arm in enumerate(self.arms):
                self.grip[arm] = float(target[a, 7] > 0.5)
            if changed or self.dwell_steps:
                self.settle = self.settle_steps if changed else self.dwell_steps
            else:
                self.index, self.steps = self.index + 1, 0
        return out


KEYS = {"w": (0, 1), "s": (0, -1), "a": (1, 1), "d": (1, -1), "r": (2, 1), "f": (2, -1)}  # axis, sign


@dataclass
class KeyboardTeleop:
    """Keys move the selected arm's hand: w/s x, a/d y, r/f z (``step_m`` per key press), g toggles its
    gripper, tab selects the next arm, q ends the demonstration. ``keys`` replaces the terminal (tests,
    scripted sessions)."""

    step_m: float = 0.01
    keys: Iterator[str] | None = None

    def start(self, robot: Any) -> None:
        self.arms = list(robot.arm_names)
        self.selected = 0
        self.targets: dict[str, list] | None = None

    def _next_key(self) -> str | None:
        if self.keys is not None:
            return next(self.keys, "q")
        if select.select([sys.stdin], [], [], 0.05)[0]:
            return sys.stdin.read(1)
        return None

    def command(self, reading: dict[str, Any]) -> Command | None:
        if self.targets is None:
            self.targets = {arm: [np.asarray(reading[f"{arm}_ee_pose"], np.float64)[:3].copy(),
                                  np.asarray(reading[f"{arm}_ee_pose"], np.float64)[3:7].copy(),
                                  float(reading[f"{arm}_gripper_open"])] for arm in self.arms}
        key = self._next_key()
        arm = self.arms[self.selected]
        if key == "q":
            return None
        if key == "\t":
            self.selected = (self.selected + 1) % len(self.arms)
        elif key == "g":
            self.targets[arm][2] = 1.0 - self.targets[arm][2]
        elif key in KEYS:
            axis, sign = KEYS[key]
            self.targets[arm][0][axis] += sign * self.step_m
        return {a: (t[0].copy(), t[1].copy(), t[2]) for a, t in self.targets.items()}
