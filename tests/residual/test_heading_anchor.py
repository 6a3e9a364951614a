"""The heading anchor (residual/heading_anchor.py): a slot is anchored in the frame where the demos' grasps are
steadiest, only where that beats the prior, and an anchored base orientation follows its frame."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation

from bimanualshift.perception.goal_geometry import GOAL_GEOMETRY_DIM
from bimanualshift.residual.heading_anchor import (
    ANCHOR_WIDTH,
    FRAMES,
    anchored_base,
    anchored_quats,
    fit_anchors,
    goal_heading,
)
from bimanualshift.residual.manager import ResidualConfig

DOWN = Rotation.from_euler("x", np.pi)  # a gripper pointing down


def goals(headings: np.ndarray, seen: bool = True) -> np.ndarray:
    g = np.zeros((len(headings), GOAL_GEOMETRY_DIM))
    g[:, 9] = float(seen)  # the box's found flag
    g[:, 13], g[:, 14] = np.cos(headings), np.sin(headings)  # this arm's end's direction into the object
    return g


def grasps(yaws: np.ndarray) -> np.ndarray:
    return (Rotation.from_euler("z", yaws[:, None]) * DOWN).as_quat()


def test_each_slot_takes_the_steadier_frame_where_it_beats_the_prior() -> None:
    rng = np.random.default_rng(0)
    headings = rng.uniform(-0.8, 0.8, 60)
    phase = np.repeat([0, 1, 2], 20)
    # slot 0 turns with the goal's end; slot 1 keeps one yaw on the table; slot 2 too, but the prior gets it right
    yaws = np.select([phase == 0, phase == 1], [headings + 0.5, 0.3], 0.3) + rng.normal(0, 0.02, 60)
    prior = grasps(np.where(phase == 2, yaws + 0.01, yaws + rng.uniform(-0.6, 0.6, 60)))
    anchors, report = fit_anchors(phase, 3, goals(headings), grasps(yaws), prior)
    assert [r["frame"] for r in report] == ["goal", "table", "none"]
    assert report[0]["goal_spread_deg"] < 3 < report[0]["prior_error_deg"] < report[0]["table_spread_deg"]
    table = np.asarray(anchors).reshape(3, ANCHOR_WIDTH)
    assert table[0, 0] == FRAMES.index("goal") and table[1, 0] == FRAMES.index("table") and not table[2].any()
    # slot 0's grasp is half a radian from the heading (or its half-turn twin, the same parallel grasp)
    assert abs(np.dot(table[0, 1:], (Rotation.from_euler("z", 0.5) * DOWN).as_quat())) > 0.999 or abs(
        np.dot(table[0, 1:], (Rotation.from_euler("z", 0.5 + np.pi) * DOWN).as_quat())) > 0.999
    # without the prior's proposals only the goal's frame can be chosen, where it beats the table's
    assert [r["frame"] for r in fit_anchors(phase, 3, goals(headings), grasps(yaws))[1]] == ["goal", "none", "none"]


def test_anchored_rows_take_their_frames_grasp_and_the_others_keep_the_prior() -> None:
    grasp = (Rotation.from_euler("z", 0.5) * DOWN).as_quat()
    anchors = (FRAMES.index("goal"), *grasp, FRAMES.index("table"), *grasp, *[0.0] * ANCHOR_WIDTH)
    headings = np.array([0.2, -0.4, 0.2, 0.2, 0.2])
    goal = goals(headings)
    goal[3, 9] = 0.0  # this row's goal was not seen
    phase = np.array([0, 0, 2, 0, 1])
    base = grasps(np.ones(5))
    out = anchored_quats(anchors, phase, goal, base, scene_yaw=np.array([0.0, 0.0, 0.0, 0.0, 0.1]))
    for row, turn in ((0, 0.2), (1, -0.4), (4, 0.1)):  # the goal's end direction; the table's, turned by the scene
        expected = (Rotation.from_euler("z", turn) * Rotation.from_quat(grasp)).as_quat()
        assert abs(abs(np.dot(out[row], expected)) - 1.0) < 1e-9
    np.testing.assert_array_equal(out[2:4], base[2:4])  # slot 2 is not anchored; row 3 saw no goal
    rows = torch.as_tensor(np.c_[np.zeros((5, 3)), base, np.ones(5)], dtype=torch.float32)
    moved = anchored_base(anchors, torch.nn.functional.one_hot(torch.as_tensor(phase), 3), torch.as_tensor(goal),
                          rows)
    np.testing.assert_allclose(moved[:4, 3:7].numpy(), out[:4], atol=1e-6)
    assert torch.equal(moved[:, :3], rows[:, :3]) and torch.equal(moved[:, 7], rows[:, 7])


def test_the_heading_needs_the_goals_extremities_and_the_config_its_inputs() -> None:
    with pytest.raises(ValueError, match="no extremities"):
        goal_heading(np.zeros((2, 10)))
    heading, seen = goal_heading(goals(np.array([0.3]), seen=False))
    assert not seen[0]
    with pytest.raises(ValueError, match="phase one-hot"):
        ResidualConfig(feature_dim=4, text_dim=4, heading_anchor=True, goal_dim=22)
    with pytest.raises(ValueError, match="a frame and a quaternion per slot"):
        ResidualConfig(feature_dim=4, text_dim=4, heading_anchor=True, goal_dim=22, phase_dim=4,
                       heading_anchors=(0.0,) * 16)
