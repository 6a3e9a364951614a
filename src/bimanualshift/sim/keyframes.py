"""Keyframe discovery from a dense trajectory, with the heuristic RLBench2 / PerAct² use.

Frame i is a keyframe if any gripper's open state changes there, or if every arm has (nearly) stopped
moving; the last frame is always a keyframe. One pause yields one keyframe however long it lasts: after a
keyframe at rest (or a gripper change) the next pause keyframe waits until some arm has moved again. A
teleoperated demonstration pauses for seconds (a blocked push, a person deciding); counting every few still
frames of it as another keyframe would cut one grasp into dozens.
"""

from __future__ import annotations

import numpy as np


def discover_keyframes(gripper_open: np.ndarray, joint_velocities: np.ndarray, stopped_below: float = 0.1,
                       debounce: int = 4, hand_positions: np.ndarray | None = None, moved_m: float = 0.01,
                       moving_above: float = 0.3) -> list[int]:
    """Keyframe indices of a trajectory.

    ``gripper_open``: (T, n_arms) in {0, 1}; ``joint_velocities``: (T, n_arms, n_joints) in rad/s. The arms rest
    below ``stopped_below``; after a keyframe they count as moving again once some hand is ``moved_m`` from where
    it was at that keyframe (``hand_positions`` (T, n_arms, 3), metres), or without positions once some joint
    turns faster than ``moving_above``: a hand settling at its target (or closing on an object) wavers about the
    rest bound, and each crossing is not a new pause.
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
    pos = None if hand_positions is None else np.asarray(hand_positions, dtype=float)[..., :3]
    if pos is not None and pos.shape[:2] != vel.shape[:2]:
        raise ValueError(f"hand_positions {pos.shape} must have joint_velocities' (T, arms) {vel.shape[:2]}")

    def moving(i: int, since: int) -> bool:
        if pos is not None:
            return bool(np.any(np.linalg.norm(pos[i] - pos[since], axis=-1) > moved_m))
        return bool(np.any(np.abs(vel[i]) > moving_above))

    keyframes: list[int] = []
    buffer = 0
    keyed_at_rest = False  # this pause already has its keyframe
    for i in range(1, T):
        changed = bool(np.any(grip[i] != grip[i - 1]))
        still = bool(np.all(np.abs(vel[i]) < stopped_below))
        if keyed_at_rest and moving(i, keyframes[-1]):
            keyed_at_rest = False
        steady_grip = i < T - 1 and not np.any(grip[i + 1] != grip[i]) and not changed
        stopped = still and steady_grip and buffer <= 0 and i < T - 2 and not keyed_at_rest
        buffer = debounce if stopped else buffer - 1
        if changed or stopped:
            keyframes.append(i)
            keyed_at_rest = True
    if not keyframes or keyframes[-1] != T - 1:
        # the end is the last keyframe; one the arms have not moved away from since is the same keyframe
        if keyframes and (T - 1 - keyframes[-1] <= 1 or not any(moving(i, keyframes[-1])
                                                                 for i in range(keyframes[-1] + 1, T))):
            keyframes.pop()
        keyframes.append(T - 1)
    return keyframes

