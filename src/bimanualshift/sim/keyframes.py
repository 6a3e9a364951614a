"""Keyframe discovery from a dense trajectory, with the heuristic RLBench2 / PerAct² use.

Frame i is a keyframe if any gripper's open state changes there, or if every arm has (nearly) stopped
moving, debounced so one pause yields one keyframe; the last frame is always a keyframe.
"""

from __future__ import annotations

import numpy as np


def discover_keyframes(gripper_open: np.ndarray, joint_velocities: np.ndarray, stopped_below: float = 0.1,
                       debounce: int = 4) -> list[int]:
    """Keyframe indices of a trajectory.

    ``gripper_open``: (T, n_arms) in {0, 1}; ``joint_velocities``: (T, n_arms, n_joints) in rad/s.
    """
    grip = np.asarray(gripper_open, dtype=float)
    vel = np.asarray(joint_velocities, dtype=float)
    if grip.ndim != 2 or vel.ndim != 3 or len(grip) != len(vel) or grip.shape[1] != vel.shape[1]:
        raise ValueError(f"expected gripper_open (T, arms) and joint_velocities (T, arms, joints) with the same "
                         f"T and arms; got {grip.shape} and {vel.shape}")
    if len(grip) == 0:
        raise ValueError("the trajectory is empty")
    if not (np.all(np.isfinite(grip)) and np.all(np.isfinite(vel))):
        raise ValueError("the trajectory contains NaN or infinite values")
    T = len(grip)
    keyframes: list[int] = []
    buffer = 0
    for i in range(1, T):
        changed = bool(np.any(grip[i] != grip[i - 1]))
        steady_grip = i < T - 1 and not np.any(grip[i + 1] != grip[i]) and not changed
        stopped = bool(np.all(np.abs(vel[i]) < stopped_below)) and steady_grip and buffer <= 0 and i < T - 2
        buffer = debounce if stopped else buffer - 1
        if changed or stopped:
            keyframes.append(i)
    if not keyframes or keyframes[-1] != T - 1:
        keyframes.append(T - 1)
    # A pause right before the end is the same keyframe as the end.
    if len(keyframes) > 1 and keyframes[-1] - keyframes[-2] <= 1:
        keyframes.pop(-2)
    return keyframes
