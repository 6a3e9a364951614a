from pathlib import Path

import numpy as np

from bimanualshift.data.episode import read_episode
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.geometry.cameras import depth_to_world_points
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.goal_geometry import (
    BOX_GEOMETRY_DIM,
    GOAL_GEOMETRY_DIM,
    OBJECT_SLOTS,
    UNION_GEOMETRY_DIM,
    goal_geometry,
    object_boxes,
)
from bimanualshift.perception.observation import DEFAULT_ARM_BOUNDS, ArmObservationBuilder
from bimanualshift.perception.projection import ArmProjection
from bimanualshift.perception.segmenters.simulator import SimulatorSegmenter

BOUNDS = (-1.0, -1.0, -1.0, 1.0, 1.0, 1.0)


def test_centroid_and_extent_in_the_arm_frame() -> None:
    frame = ArmFrame((0.5, 0.0, 0.0))  # a base 0.5 m along world x
    rng = np.random.default_rng(0)
    points = rng.uniform([0.6, -0.1, 0.0], [0.8, 0.1, 0.1], size=(2000, 3))
    geometry = goal_geometry(points, frame, BOUNDS)
    expected = frame.points_to_arm(points)
    np.testing.assert_allclose(geometry[:3], expected.mean(0), atol=1e-5)
    np.testing.assert_allclose(geometry[3:6], np.percentile(expected, 5, axis=0), atol=1e-5)
    np.testing.assert_allclose(geometry[6:9], np.percentile(expected, 95, axis=0), atol=1e-5)
    assert geometry[9] == 1.0


def test_points_outside_the_workspace_or_too_few_count_as_unseen() -> None:
    frame = ArmFrame((0.0, 0.0, 0.0))
    far = np.full((50, 3), 5.0)
    np.testing.assert_array_equal(goal_geometry(far, frame, BOUNDS), np.zeros(UNION_GEOMETRY_DIM))
    np.testing.assert_array_equal(goal_geometry(np.zeros((3, 3)), frame, BOUNDS), np.zeros(UNION_GEOMETRY_DIM))
    mixed = np.r_[far, np.full((20, 3), 0.25)]  # the outliers are dropped, not averaged in
    np.testing.assert_allclose(goal_geometry(mixed, frame, BOUNDS)[:3], frame.points_to_arm(np.full((1, 3), 0.25))[0],
                               atol=1e-6)


def test_projection_locates_the_goal_object_of_a_real_scene(bimanual_episode_path: Path) -> None:
    ep = read_episode(bimanual_episode_path)
    obs = KeyframeObservation.from_episode(ep, 0)
    builder = ArmObservationBuilder(VoxelGrid(DEFAULT_ARM_BOUNDS, 16), ArmProjection(SimulatorSegmenter()),
                                    goal_objects=True)
    per_arm = builder.build(obs)
    # without goal_objects the union's geometry is the same and the per-object boxes are not computed (zeros)
    union_only = ArmObservationBuilder(VoxelGrid(DEFAULT_ARM_BOUNDS, 16), ArmProjection(SimulatorSegmenter()))
    for arm, observed in union_only.build(obs).items():
        np.testing.assert_array_equal(observed.goal[:UNION_GEOMETRY_DIM], per_arm[arm].goal[:UNION_GEOMETRY_DIM])
        assert observed.goal.shape == (GOAL_GEOMETRY_DIM,) and not observed.goal[UNION_GEOMETRY_DIM:].any()
    # Ground truth from the simulator's instance ids: every pixel of a named button (the instruction's colours;
    # the third button is a distractor), back-projected.
    named = {prompt.split()[0] for prompt in ep.goal_nouns}
    buttons = [i for i, n in enumerate(ep.instance_names)
               if n.startswith("button") and named & set(ep.instance_colours[n])]
    assert len(buttons) == 2
    truth = np.concatenate([depth_to_world_points(obs.depth[c], obs.intrinsics[c], obs.extrinsics[c])[
        np.isin(obs.instance[c], buttons) & (obs.depth[c] > 0)] for c in range(len(obs.depth))])
    for arm in ep.arm_names:
        frame = ArmFrame(tuple(ep.arm_bases[arm]))
        geometry = per_arm[arm].goal
        assert geometry[9] == 1.0
        in_arm = frame.points_to_arm(truth)
        inside = np.all((in_arm >= DEFAULT_ARM_BOUNDS[:3]) & (in_arm <= DEFAULT_ARM_BOUNDS[3:]), axis=1)
        assert inside.sum() > 50
        np.testing.assert_allclose(geometry[:3], in_arm[inside].mean(0), atol=0.01)
        # each named button gets its own box, in the goal nouns' order, after the union's box and extremities;
        # a button outside this arm's workspace is not seen by it
        seen = 0
        for slot, prompt in enumerate(ep.goal_nouns):
            button = next(i for i in buttons if prompt.split()[0] in ep.instance_colours[ep.instance_names[i]])
            own = frame.points_to_arm(np.concatenate([depth_to_world_points(
                obs.depth[c], obs.intrinsics[c], obs.extrinsics[c])[(obs.instance[c] == button) & (obs.depth[c] > 0)]
                for c in range(len(obs.depth))]))
            own = own[np.all((own >= DEFAULT_ARM_BOUNDS[:3]) & (own <= DEFAULT_ARM_BOUNDS[3:]), axis=1)]
            box = geometry[UNION_GEOMETRY_DIM + slot * BOX_GEOMETRY_DIM:][:BOX_GEOMETRY_DIM]
            assert box[9] == float(len(own) >= 10)
            if len(own) >= 10:
                np.testing.assert_allclose(box[:3], own.mean(0), atol=0.01)
                seen += 1
        assert seen >= 1
        assert geometry.shape == (GOAL_GEOMETRY_DIM,) and not geometry[UNION_GEOMETRY_DIM + 2 * BOX_GEOMETRY_DIM:].any()
    # Without a projection nothing is segmented, so the goal is not located.
    plain = ArmObservationBuilder(VoxelGrid(DEFAULT_ARM_BOUNDS, 16)).build(obs)
    assert plain["left"].goal.shape == (GOAL_GEOMETRY_DIM,) and not plain["left"].goal.any()


def test_object_boxes_give_each_goal_its_own_box_in_order() -> None:
    frame = ArmFrame((0.0, 0.0, 0.0))
    rng = np.random.default_rng(0)
    big = rng.uniform([0.4, -0.2, 0.0], [0.7, 0.2, 0.3], size=(3000, 3))  # an oven
    small = rng.uniform([0.45, 0.05, 0.05], [0.55, 0.1, 0.07], size=(200, 3))  # a tray beside its middle
    boxes = object_boxes([small, big, np.zeros((0, 3)), small], frame, BOUNDS)  # unseen third, fourth beyond
    assert boxes.shape == (OBJECT_SLOTS * BOX_GEOMETRY_DIM,)
    np.testing.assert_allclose(boxes[:BOX_GEOMETRY_DIM], goal_geometry(small, frame, BOUNDS)[:BOX_GEOMETRY_DIM])
    np.testing.assert_allclose(boxes[BOX_GEOMETRY_DIM:2 * BOX_GEOMETRY_DIM],
                               goal_geometry(big, frame, BOUNDS)[:BOX_GEOMETRY_DIM])
    assert not boxes[2 * BOX_GEOMETRY_DIM:].any()
    # the union's box is the oven's: it cannot say where the tray is, the tray's own box does
    union = goal_geometry(np.r_[big, small], frame, BOUNDS)
    assert abs(union[1] - 0.075) > 0.05 and abs(boxes[1] - 0.075) < 0.005


def curved_chain(rng: np.random.Generator, points_per_cm: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A 1 cm thick S-curve 0.6 m long lying on a table in front of the arm, its two ends and its samples."""
    s = np.linspace(0.0, 1.0, 60 * points_per_cm)
    centre = np.stack([0.5 + 0.12 * np.sin(2 * np.pi * s), -0.3 + 0.6 * s, np.zeros_like(s)], axis=1)
    cloud = centre + rng.normal(0.0, 0.003, size=centre.shape)
    return cloud, centre[0], centre[-1]


def test_extremities_are_the_ends_of_a_curve_not_its_box_corners() -> None:
    from bimanualshift.perception.goal_geometry import BOX_GEOMETRY_DIM, TIP_LENGTH_M

    cloud, start, end = curved_chain(np.random.default_rng(0))
    frame = ArmFrame((0.0, 0.0, 0.0))
    geometry = goal_geometry(cloud, frame, BOUNDS)
    first, second = geometry[BOX_GEOMETRY_DIM:BOX_GEOMETRY_DIM + 6], geometry[BOX_GEOMETRY_DIM + 6:]
    # the tips lie within half a tip length of the true ends (the tip is the mean of the last TIP_LENGTH_M)
    tips = sorted([first[:3], second[:3]], key=lambda t: t[1])
    assert np.linalg.norm(tips[0] - start) < TIP_LENGTH_M / 2 + 0.005
    assert np.linalg.norm(tips[1] - end) < TIP_LENGTH_M / 2 + 0.005
    # ordered by |y|: both ends are 0.3 m to the side here; shift the cloud so one end is nearer the arm
    shifted = goal_geometry(cloud + [0.0, 0.1, 0.0], frame, BOUNDS)
    np.testing.assert_allclose(shifted[BOX_GEOMETRY_DIM:BOX_GEOMETRY_DIM + 3], start + [0.0, 0.1, 0.0], atol=0.025)
    # each direction is a horizontal unit vector pointing from the tip into the curve
    for part, tip in ((shifted[BOX_GEOMETRY_DIM:BOX_GEOMETRY_DIM + 6], start), (shifted[BOX_GEOMETRY_DIM + 6:], end)):
        direction = part[3:6]
        assert abs(np.linalg.norm(direction) - 1.0) < 1e-5 and direction[2] == 0.0
        inward = (cloud[40 if tip is start else -40] - tip)[:2]
        assert direction[:2] @ inward / np.linalg.norm(inward) > 0.8


def test_extremities_keep_to_the_largest_piece_and_are_deterministic() -> None:
    cloud, start, _ = curved_chain(np.random.default_rng(1))
    stray = np.random.default_rng(2).normal([0.8, 0.4, 0.0], 0.002, size=(15, 3))  # a small far-off blob
    frame = ArmFrame((0.0, 0.0, 0.0))
    with_stray = goal_geometry(np.r_[cloud, stray], frame, BOUNDS)
    for tip in (with_stray[10:13], with_stray[16:19]):  # neither end is the blob
        assert np.linalg.norm(tip - stray.mean(0)) > 0.2
    np.testing.assert_array_equal(with_stray, goal_geometry(np.r_[cloud, stray], frame, BOUNDS))
