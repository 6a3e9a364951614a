"""Client-side safety limits: in-bounds commands pass unchanged, the rest is clipped and reported."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bimanualshift.deploy.safety import SafetyFilter, SafetyLimits

LIMITS = SafetyLimits((-0.5, -0.5, 0.8), (0.5, 0.5, 1.4), max_translation_m=0.1, max_rotation_rad=0.5,
                      gripper_debounce=2)
UP = np.array([0.0, 0.0, 1.0, 0, 0, 0, 1])


def started() -> SafetyFilter:
    f = SafetyFilter(LIMITS)
    f.start(UP, 1.0)
    return f


def test_in_bounds_commands_are_unchanged() -> None:
    f = started()
    target = np.array([0.05, 0.05, 1.05, *Rotation.from_euler("z", 0.3).as_quat()])
    pose, grip, clipped = f.apply(target, 1.0)
    assert clipped == [] and np.array_equal(pose, target) and grip == 1.0


def test_workspace_and_step_limits() -> None:
    f = started()
    pose, _, clipped = f.apply(np.array([0.0, 0.0, 0.5, 0, 0, 0, 1]), 1.0)  # below the table, 50 cm away
    assert "workspace" in clipped and "translation step" in clipped
    assert pose[2] == pytest.approx(0.9)  # 10 cm towards the clipped target
    pose, _, clipped = f.apply(np.r_[pose[:3], Rotation.from_euler("x", 2.0).as_quat()], 1.0)
    assert clipped == ["rotation step"]
    assert (Rotation.from_quat(pose[3:]).magnitude()) == pytest.approx(0.5)


def test_gripper_is_debounced_and_non_finite_commands_hold() -> None:
    f = started()
    assert f.apply(UP, 0.0)[1:] == (1.0, ["gripper debounce"])
    assert f.apply(UP, 0.0)[1:] == (0.0, [])  # asked twice in a row: it closes
    pose, grip, clipped = f.apply(np.full(7, np.nan), 1.0)
    assert np.array_equal(pose, UP) and grip == 0.0 and "non-finite" in clipped[0]


def test_limits_are_checked() -> None:
    with pytest.raises(ValueError, match="below"):
        SafetyLimits((0, 0, 1), (1, 1, 0.5))


def test_executor_streams_keyframes_at_the_robots_rate() -> None:
    from bimanualshift.deploy.executor import KeyframeExecutor

    ex = KeyframeExecutor(rate_hz=100.0, max_speed_m_s=0.2, max_angular_speed_rad_s=1.0)
    target = np.array([0.1, 0.0, 1.0, *Rotation.from_euler("z", 0.5).as_quat()])
    path = ex.waypoints(UP, target)
    assert len(path) == 50  # 10 cm at 2 mm per 10 ms period
    assert np.allclose(path[-1], target)
    assert np.linalg.norm(np.diff(np.r_[UP[None, :3], path[:, :3]], axis=0), axis=1).max() <= 0.002 + 1e-9
    turns = (Rotation.from_quat(path[1:, 3:]) * Rotation.from_quat(path[:-1, 3:]).inv()).magnitude()
    assert turns.max() <= 0.01 + 1e-9
    chunk = ex.chunk_waypoints(UP, np.stack([target, UP]))
    assert len(chunk) == 100 and np.allclose(chunk[-1], UP)
