"""The arm-frame coverage measure: poses come from the tasks' own resets, in each arm's base frame."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.coverage import SKILL_PAIRS, arm_frame_poses, coverage
from bimanualshift.sim.layout import BIMANUAL_ARM_Y
from bimanualshift.sim.task import task_names


def test_every_pair_names_a_bimanual_task_and_a_single_arm_one() -> None:
    assert set(SKILL_PAIRS) == set(task_names(bimanual=True))
    singles = {s for pairs in SKILL_PAIRS.values() for s in pairs.values() if s}
    assert singles <= set(task_names(bimanual=False))


def test_the_two_arms_see_one_object_shifted_by_their_bases() -> None:
    poses = arm_frame_poses("pick_up_plate", "plate", [0, 1, 2])
    shift = BIMANUAL_ARM_Y["left"] - BIMANUAL_ARM_Y["right"]
    assert poses["left"].shape == (3, 3)
    assert np.allclose(poses["right"][:, 1] - poses["left"][:, 1], shift)
    assert np.allclose(poses["right"][:, [0, 2]], poses["left"][:, [0, 2]])


def test_coverage_counts_the_poses_inside_the_single_arm_range() -> None:
    rows = {(r.obj, r.arm): r for r in coverage("take_tray_out_of_oven", [0, 1, 2, 3], [0, 1, 2, 3])}
    oven = rows[("oven", "left")]
    assert oven.single_arm_task == "open_oven_door" and 0.0 <= oven.inside <= 1.0
    lo, hi = np.array(oven.single_arm_range).T
    b_lo, b_hi = np.array(oven.bimanual_range).T
    # the measure agrees with the ranges it reports: all inside only if the bimanual box lies in the single-arm one
    assert (oven.inside == 1.0) == bool(np.all(b_lo >= lo) and np.all(b_hi <= hi))
