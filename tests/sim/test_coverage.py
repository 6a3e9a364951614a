"""Arm-frame coverage: in each arm's base frame, every goal object of every bimanual task lies where the
matching single-arm task's own resets put that kind of object (the data a frozen prior is pretrained on)."""

from __future__ import annotations

import numpy as np
import pytest

from bimanualshift.data.seeds import split_seeds
from bimanualshift.sim.coverage import SKILL_PAIRS, arm_frame_goal_poses, coverage, covered, single_arm_tasks
from bimanualshift.sim.layout import BIMANUAL_ARM_Y
from bimanualshift.sim.task_registry import task_groups, task_names

BIMANUAL_SEEDS = split_seeds("test", 100)  # where the bimanual tasks are evaluated
SINGLE_ARM_SEEDS = split_seeds("train", 600)  # where the pretraining demonstrations come from


def test_every_pair_names_a_bimanual_task_and_a_single_arm_one() -> None:
    assert set(SKILL_PAIRS) == set(task_names(bimanual=True, robot="panda")) | set(task_groups()["realworld"])
    singles = set().union(*(single_arm_tasks(task) for task in SKILL_PAIRS))
    assert singles <= set(task_names(bimanual=False))


def test_the_two_arms_see_one_object_shifted_by_their_bases() -> None:
    poses = arm_frame_goal_poses("pick_up_plate", [0, 1, 2])["plate"]
    shift = BIMANUAL_ARM_Y["left"] - BIMANUAL_ARM_Y["right"]
    assert poses["left"].shape == (3, 3)
    assert np.allclose(poses["right"][:, 1] - poses["left"][:, 1], shift)
    assert np.allclose(poses["right"][:, [0, 2]], poses["left"][:, [0, 2]])


def test_each_arm_is_given_only_the_objects_it_acts_on() -> None:
    poses = arm_frame_goal_poses("take_tray_out_of_oven", [0, 1, 2, 3])
    assert set(poses) == {"oven", "tray"}
    for kind in poses:  # one arm opens the door, the other takes the tray: never both on one object
        assert sum(len(p) for p in poses[kind].values()) == 4


def test_covered_needs_a_nearby_sample_not_just_the_range() -> None:
    reference = np.array([[0.5, -0.3, 0.0], [0.5, 0.3, 0.0]])  # two clusters: the box between them is empty
    poses = np.array([[0.5, 0.0, 0.0], [0.5, 0.28, 0.0], [0.5, 0.28, 1.0]])
    assert covered(poses, reference, use_yaw=False).tolist() == [False, True, True]
    assert covered(poses, reference, use_yaw=True).tolist() == [False, True, False]


@pytest.mark.parametrize("task", sorted(SKILL_PAIRS))
def test_single_arm_data_covers_every_bimanual_goal_in_each_arm_frame(task: str) -> None:
    for row in coverage(task, BIMANUAL_SEEDS, SINGLE_ARM_SEEDS):
        assert row.inside == 1.0, (
            f"{task}: {row.arm} arm's {row.obj} reaches {row.bimanual_range} (x, y, yaw) but "
            f"{row.single_arm_task} samples {row.single_arm_range}; worst gap {row.farthest_cm} cm")
