"""A parallel grasp's twin half a turn about the gripper's axis is chosen when it lies nearer the prior's
proposal, and the rotation residual's target follows the switch."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bimanualshift.geometry.frames import grasp_twin_mean, nearest_grasp_twin, rotation_difference
from bimanualshift.residual.manager import ResidualConfig
from bimanualshift.training.residual_data import rotation_target, slot_twin_references


def _down(yaw_deg: float) -> np.ndarray:
    """The gripper pointing down, turned ``yaw_deg`` about the vertical ((x, y, z, w))."""
    return (Rotation.from_euler("z", yaw_deg, degrees=True) * Rotation.from_euler("x", np.pi)).as_quat()


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees((Rotation.from_quat(a).inv() * Rotation.from_quat(b)).magnitude()))


@pytest.mark.parametrize("expert_yaw", [4.0, 176.0])  # sweep's dustpan grasp comes as either twin
def test_the_twin_nearer_the_proposal_is_the_target(expert_yaw: float) -> None:
    prior = _down(85.0)
    chosen = nearest_grasp_twin(_down(expert_yaw), prior)
    # either way the demo gives it, the target is the twin on the 0-degree side: a turn of 81 or 89 degrees the
    # same way, where the expert's own quaternions ask 81 one way or 91 the other
    assert _angle_deg(chosen, prior) == pytest.approx(81.0 if expert_yaw == 4.0 else 89.0, abs=1e-6)
    x = Rotation.from_quat(chosen).apply([1.0, 0, 0])
    assert abs(np.degrees(np.arctan2(x[1], x[0]))) == pytest.approx(4.0, abs=1e-6)
    # the twin is the same grasp: the gripper still points down, its fingers along the same line
    z = Rotation.from_quat(chosen).apply([0, 0, 1.0])
    assert z == pytest.approx([0, 0, -1.0], abs=1e-9)
    x_chosen, x_expert = Rotation.from_quat(chosen).apply([1.0, 0, 0]), Rotation.from_quat(_down(expert_yaw)).apply(
        [1.0, 0, 0])
    assert abs(float(x_chosen @ x_expert)) == pytest.approx(1.0)


def test_a_target_nearer_than_its_twin_is_kept() -> None:
    expert = _down(30.0)
    np.testing.assert_allclose(nearest_grasp_twin(expert, _down(0.0)), expert)


def test_the_residual_target_follows_the_switch() -> None:
    prior, expert = _down(85.0), _down(176.0)
    kept = rotation_target(ResidualConfig(feature_dim=4, text_dim=4), expert, prior)
    np.testing.assert_allclose(kept, rotation_difference(expert, prior))
    assert np.degrees(np.linalg.norm(kept)) == pytest.approx(91.0, abs=1e-6)
    twin = rotation_target(ResidualConfig(feature_dim=4, text_dim=4, rotation_target="nearest_twin"), expert, prior)
    assert np.degrees(np.linalg.norm(twin)) == pytest.approx(89.0, abs=1e-6)
    with pytest.raises(ValueError, match="rotation_target"):
        ResidualConfig(feature_dim=4, text_dim=4, rotation_target="twin")


def test_the_mean_of_grasps_wrapped_either_way_is_their_heading() -> None:
    # sweep's dustpan grasp: headings 0-8 degrees, half of them given as their twin (172-180)
    headings = np.linspace(0.0, 8.0, 9)
    given = np.stack([_down(h + 180.0 * (i % 2)) for i, h in enumerate(headings)])
    mean = grasp_twin_mean(given)
    assert min(_angle_deg(mean, _down(4.0)), _angle_deg(mean, _down(184.0))) == pytest.approx(0.0, abs=0.5)
    # each grasp taken as the twin nearer that mean lies within 4 degrees of it
    assert max(_angle_deg(nearest_grasp_twin(q, mean), mean) for q in given) == pytest.approx(4.0, abs=0.5)


def _slot_config(slots: int = 3, **kwargs: object) -> ResidualConfig:
    return ResidualConfig(feature_dim=4, text_dim=4, phase_dim=2 * slots, rotation_target="slot_twin", **kwargs)


def test_slot_references_make_every_target_turn_the_same_way() -> None:
    config = _slot_config()
    rng = np.random.default_rng(0)
    # arm 0's keyframe 0: headings 0-8 degrees given as either twin; arm 0's keyframe 1 the same grasp lifted
    # (headings 170-178 here, the twin side the demos happen to give); arm 1 at 45 degrees throughout
    headings = rng.uniform(0.0, 8.0, 20)
    quats = np.stack([_down(h + 180.0 * (i % 2)) for i, h in enumerate(headings)]
                     + [_down(h + 170.0) for h in headings[:5]] + [_down(45.0)] * 4)
    arm = np.r_[np.zeros(25, int), np.ones(4, int)]
    keyframe = np.r_[np.zeros(20, int), np.ones(5, int), [0, 1, 2, 7]]  # past the last slot: shares the last
    references = slot_twin_references(config, arm, keyframe, quats)
    config = replace(config, twin_references=references)
    first = config.twin_reference(0, 0)
    # keyframe 1's mean is taken as the twin nearer keyframe 0's: the wrist does not spin half a turn between them
    assert _angle_deg(config.twin_reference(0, 1), first) < 15.0
    assert _angle_deg(config.twin_reference(0, 2), config.twin_reference(0, 1)) == pytest.approx(0.0, abs=1e-6)
    assert _angle_deg(config.twin_reference(1, 2), _down(45.0)) == pytest.approx(0.0, abs=1e-4)
    prior = _down(85.0)
    turns = np.stack([rotation_target(config, q, prior, first) for q in quats[:20]])
    # every keyframe-0 target is one turn about the vertical, all the same way, of 77-95 degrees
    assert np.all(np.sign(turns[:, 2]) == np.sign(turns[0, 2]))
    assert np.degrees(np.linalg.norm(turns, axis=1)).min() > 76.0
    assert np.degrees(np.linalg.norm(turns, axis=1)).max() < 96.0
    # with the expert's targets the same demos ask both ways
    expert = np.stack([rotation_target(ResidualConfig(feature_dim=4, text_dim=4), q, prior) for q in quats[:20]])
    assert len(set(np.sign(expert[:, 2]))) == 2


def test_slot_twin_needs_the_phase_and_its_references() -> None:
    with pytest.raises(ValueError, match="phase one-hot"):
        ResidualConfig(feature_dim=4, text_dim=4, rotation_target="slot_twin")
    with pytest.raises(ValueError, match="twin_references holds 4 numbers"):
        _slot_config(twin_references=(0.0, 0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="no twin references"):
        _slot_config().twin_reference(0, 0)
    with pytest.raises(ValueError, match="twin reference"):
        rotation_target(_slot_config(), _down(0.0), _down(85.0))
