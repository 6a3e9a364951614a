"""Keyframe discovery finds gripper changes, pauses (once each) and the last frame."""

from __future__ import annotations

import numpy as np
import pytest

from bimanualshift.sim.keyframes import discover_keyframes


def synthetic(moves: list[tuple[int, int]], grip_changes: dict[int, tuple[int, float]], T: int = 60,
              arms: int = 2) -> tuple[np.ndarray, np.ndarray]:
    vel = np.zeros((T, arms, 7))
    for start, stop in moves:
        vel[start:stop] = 1.0
    grip = np.ones((T, arms))
    for t, (arm, value) in grip_changes.items():
        grip[t:, arm] = value
    return grip, vel


def test_pauses_gripper_changes_and_the_end_are_keyframes() -> None:
    # Move 0-19, pause 20-24, move 25-39, left gripper closes at 45 (arms still), move 48-59.
    grip, vel = synthetic([(0, 20), (25, 40), (48, 60)], {45: (0, 0.0)})
    kfs = discover_keyframes(grip, vel)
    assert 20 in kfs and 40 in kfs and 45 in kfs and kfs[-1] == 59
    assert kfs == sorted(set(kfs))
    # Debounce: each pause gives one keyframe, not one per still frame.
    assert sum(20 <= k < 25 for k in kfs) == 1


def test_an_arm_still_moving_prevents_a_pause_keyframe() -> None:
    grip, vel = synthetic([(0, 30)], {}, T=40)
    vel[10:20, 1] = 0.0  # only the right arm pauses: not a keyframe
    vel[10:20, 0] = 1.0
    kfs = discover_keyframes(grip, vel)
    assert not any(10 <= k < 20 for k in kfs)


def test_bad_shapes_raise_clear_errors() -> None:
    with pytest.raises(ValueError, match="same T and arms"):
        discover_keyframes(np.ones((5, 2)), np.zeros((6, 2, 7)))
    with pytest.raises(ValueError, match="NaN"):
        discover_keyframes(np.full((5, 1), np.nan), np.zeros((5, 1, 7)))


def test_discovery_recovers_an_expert_rollouts_keyframes() -> None:
    from bimanualshift.sim.env import ManipulationEnv

    env = ManipulationEnv("push_two_buttons", image_size=64)
    env.reset(seed=5, options={"render": False})
    env.start_dense_recording()
    expert = env.expert_keyframes()
    ends = []
    for keyframe in expert:
        env.step(env.action_from_keyframe(keyframe), render=False)
        ends.append(len(env._dense) - 1)
    dense = env.dense_trajectory()
    env.close()
    assert dense["joint_positions"].shape[1:] == (2, 7) and dense["eef_pose"].shape[1:] == (2, 7)
    found = discover_keyframes(dense["gripper_open"], dense["joint_velocities"],
                               hand_positions=dense["eef_pose"])
    # Every executed keyframe ends near a discovered one (the arms stop there), or where the hands already rested
    # at one (within the 1 cm a pause allows: push two buttons' press moves 5 mm past where the arm paused)
    hands = dense["eef_pose"][:, :, :3]
    for end in ends:
        near = min(abs(k - end) for k in found) <= 8
        rested = any(np.linalg.norm(hands[end] - hands[k], axis=-1).max() <= 0.01 for k in found if k <= end)
        assert near or rested, (end, found)
    assert len(found) <= 2 * len(expert)


def test_a_long_pause_is_one_keyframe_and_settling_is_not_a_new_one() -> None:
    # teleoperated: the arms rest 20-59 (a blocked push), wavering about the rest bound while the hand settles
    grip, vel = synthetic([(0, 20), (60, 80)], {}, T=100)
    vel[20:60:3] = 0.12  # each waver crosses 0.1 rad/s
    hands = np.zeros((100, 2, 3))
    hands[:20, :, 0] = np.linspace(0, 0.2, 20)[:, None]
    hands[20:60, :, 0] = 0.2 + 0.002 * np.sin(np.arange(40))[:, None]  # millimetres of settling
    hands[60:80, :, 0] = np.linspace(0.2, 0.4, 20)[:, None]
    hands[80:, :, 0] = 0.4
    kfs = discover_keyframes(grip, vel, hand_positions=hands)
    assert sum(20 <= k < 60 for k in kfs) == 1 and kfs[-1] == 99
    assert len(kfs) == 2  # the pause and the end, where the arms rest after the last move
    # without the hands' positions the joints' speed decides when the arms move again
    assert sum(20 <= k < 60 for k in discover_keyframes(grip, vel)) == 1
