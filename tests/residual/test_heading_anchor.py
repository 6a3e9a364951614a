"""The heading anchor (residual/heading_anchor.py): a slot is anchored only where the demos' grasps follow the
goal's end direction, and an anchored base orientation turns with that direction."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation

from bimanualshift.perception.goal_geometry import GOAL_GEOMETRY_DIM
from bimanualshift.residual.heading_anchor import anchored_base, anchored_quats, fit_anchors, goal_heading
from bimanualshift.residual.manager import ResidualConfig

DOWN = Rotation.from_euler("x", np.pi)  # a gripper pointing down


def goals(headings: np.ndarray, seen: bool = True) -> np.ndarray:
    g = np.zeros((len(headings), GOAL_GEOMETRY_DIM))
    g[:, 9] = float(seen)  # the box's found flag
    g[:, 13], g[:, 14] = np.cos(headings), np.sin(headings)  # this arm's end's direction into the object
    return g


def grasps(yaws: np.ndarray) -> np.ndarray:
    return (Rotation.from_euler("z", yaws[:, None]) * DOWN).as_quat()


def test_a_slot_is_anchored_where_the_grasp_follows_the_goal_and_not_where_it_is_fixed() -> None:
    rng = np.random.default_rng(0)
    headings = rng.uniform(-0.8, 0.8, 40)
    phase = np.repeat([0, 1], 20)  # slot 0: turns with the goal; slot 1: one yaw whatever the goal
    yaws = np.where(phase == 0, headings + 0.5, 0.3) + rng.normal(0, 0.02, 40)
    anchors, report = fit_anchors(phase, 2, goals(headings), grasps(yaws))
    assert [r["anchored"] for r in report] == [True, False]
    assert report[0]["relative_spread_deg"] < 3 < report[0]["absolute_spread_deg"]
    assert np.allclose(anchors[4:], 0.0)
    # the anchor is the grasp half a radian from the heading (or its half-turn twin, the same parallel grasp)
    turn = (Rotation.from_euler("z", 0.5) * DOWN).as_quat()
    twin = (Rotation.from_quat(turn) * Rotation.from_euler("z", np.pi)).as_quat()
    assert max(abs(np.dot(anchors[:4], turn)), abs(np.dot(anchors[:4], twin))) > 0.999


def test_anchored_rows_turn_with_the_goal_and_the_others_keep_the_prior() -> None:
    anchor = (Rotation.from_euler("z", 0.5) * DOWN).as_quat()
    anchors = (*anchor, 0.0, 0.0, 0.0, 0.0)
    headings = np.array([0.2, -0.4, 0.2, 0.2])
    goal = goals(headings)
    goal[3, 9] = 0.0  # this row's goal was not seen
    phase = np.array([0, 0, 1, 0])
    base = grasps(np.array([1.0, 1.0, 1.0, 1.0]))
    out = anchored_quats(anchors, phase, goal, base)
    for row, heading in ((0, 0.2), (1, -0.4)):
        expected = (Rotation.from_euler("z", heading) * Rotation.from_quat(anchor)).as_quat()
        assert abs(abs(np.dot(out[row], expected)) - 1.0) < 1e-9
    np.testing.assert_array_equal(out[2:], base[2:])  # slot 1 is not anchored; row 3 saw no goal
    rows = torch.as_tensor(np.c_[np.zeros((4, 3)), base, np.ones(4)], dtype=torch.float32)
    moved = anchored_base(anchors, torch.nn.functional.one_hot(torch.as_tensor(phase), 2), torch.as_tensor(goal),
                          rows)
    np.testing.assert_allclose(moved[:, 3:7].numpy(), out, atol=1e-6)
    assert torch.equal(moved[:, :3], rows[:, :3]) and torch.equal(moved[:, 7], rows[:, 7])


def test_the_heading_needs_the_goals_extremities_and_the_config_its_inputs() -> None:
    with pytest.raises(ValueError, match="no extremities"):
        goal_heading(np.zeros((2, 10)))
    heading, seen = goal_heading(goals(np.array([0.3]), seen=False))
    assert not seen[0]
    with pytest.raises(ValueError, match="phase one-hot"):
        ResidualConfig(feature_dim=4, text_dim=4, heading_anchor=True, goal_dim=22)
    with pytest.raises(ValueError, match="a quaternion per slot"):
        ResidualConfig(feature_dim=4, text_dim=4, heading_anchor=True, goal_dim=22, phase_dim=4,
                       heading_anchors=(0.0,) * 8)
