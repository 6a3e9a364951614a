from pathlib import Path

import numpy as np

from bimanualshift.data.episode import read_episode
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.observation import ArmObservationBuilder
from bimanualshift.perception.projection import ArmProjection
from bimanualshift.perception.segmenters.simulator import SimulatorSegmenter


def _buttons(ep, named: bool) -> list[int]:  # noqa: ANN001
    """Instance ids of the buttons the instruction names (named=True) or of the distractor (False)."""
    colours = {prompt.split()[0] for prompt in ep.goal_nouns}
    return [i for i, n in enumerate(ep.instance_names)
            if n.startswith("button") and bool(colours & set(ep.instance_colours[n])) == named]


def test_each_arm_keeps_itself_and_the_goal_and_drops_the_other_arm(bimanual_episode_path: Path) -> None:
    ep = read_episode(bimanual_episode_path)
    assert len(_buttons(ep, True)) == 2 and len(_buttons(ep, False)) == 1
    projection = ArmProjection(SimulatorSegmenter())
    for k in range(ep.num_keyframes):
        obs = KeyframeObservation.from_episode(ep, k)
        masks = projection.masks_2d(obs)
        for arm, other in (("left", "right"), ("right", "left")):
            own = obs.instance == ep.instance_names.index(f"arm_{arm}")
            theirs = obs.instance == ep.instance_names.index(f"arm_{other}")
            goal = np.isin(obs.instance, _buttons(ep, True))
            distractor = np.isin(obs.instance, _buttons(ep, False))
            assert masks[arm][own].mean() > 0.95
            assert masks[arm][goal].mean() > 0.99
            assert masks[arm][theirs].mean() < 0.05
            assert not masks[arm][distractor].any()  # "push the blue and the navy buttons": not the third
    assert projection.diagnostics.no_goal_found == 0


def test_colour_prompts_match_every_instance_when_colours_are_unknown(bimanual_episode_path: Path) -> None:
    """A recording without painted colours (a real camera's, an older file's) keeps every button, as before."""
    ep = read_episode(bimanual_episode_path)
    ep.instance_colours = {}
    obs = KeyframeObservation.from_episode(ep, 0)
    masks = ArmProjection(SimulatorSegmenter()).masks_2d(obs)
    every_button = np.isin(obs.instance, [i for i, n in enumerate(ep.instance_names) if n.startswith("button")])
    assert masks["left"][every_button].mean() > 0.99


def test_projected_voxels_are_a_subset_of_the_global_scene(bimanual_episode_path: Path) -> None:
    ep = read_episode(bimanual_episode_path)
    obs = KeyframeObservation.from_episode(ep, 0)
    grid = VoxelGrid((-0.1, -1.0, -0.2, 1.0, 1.0, 0.8), 24)  # wide enough to hold both arms
    full = ArmObservationBuilder(grid).build(obs)
    masked = ArmObservationBuilder(grid, ArmProjection(SimulatorSegmenter())).build(obs)
    for arm in ep.arm_names:
        occ_full, occ_masked = full[arm].voxels[0] > 0, masked[arm].voxels[0] > 0
        assert occ_masked.sum() > 0
        assert np.all(occ_full[occ_masked])  # V * M_3D only removes voxels
        assert occ_masked.sum() < occ_full.sum()
        np.testing.assert_array_equal(full[arm].proprio, masked[arm].proprio)


def test_missing_arm_masks_fall_back_to_goal_and_support(bimanual_episode_path: Path) -> None:
    class NoArms(SimulatorSegmenter):
        def segment(self, view, prompts):  # noqa: ANN001, ANN201
            return [d for d in super().segment(view, prompts) if d.label != "robotic arm"]

    ep = read_episode(bimanual_episode_path)
    obs = KeyframeObservation.from_episode(ep, 0)
    projection = ArmProjection(NoArms())
    masks = projection.masks_2d(obs)
    arms = np.isin(obs.instance, [ep.instance_names.index("arm_left"), ep.instance_names.index("arm_right")])
    assert not masks["left"][arms].any()
    assert projection.diagnostics.no_arm_found == len(ep.camera_names)


def _arm_pixels(ep, obs, arm: str) -> np.ndarray:  # noqa: ANN001
    return obs.instance == ep.instance_names.index(f"arm_{arm}")


def test_merged_arms_are_split_by_side(bimanual_episode_path: Path) -> None:
    """A detector that returns both arms as one mask (crossing arms): each arm still keeps itself."""
    from bimanualshift.perception.segmenters.degraded import Degradation, DegradedSegmenter

    ep = read_episode(bimanual_episode_path)
    projection = ArmProjection(DegradedSegmenter(SimulatorSegmenter(), Degradation(merge_arms=1.0)))
    for k in range(ep.num_keyframes):
        obs = KeyframeObservation.from_episode(ep, k)
        masks = projection.masks_2d(obs)
        static = [c for c, name in enumerate(ep.camera_names) if not name.startswith("wrist")]
        for arm, other in (("left", "right"), ("right", "left")):
            own, theirs = _arm_pixels(ep, obs, arm)[static], _arm_pixels(ep, obs, other)[static]
            assert masks[arm][static][own].mean() > 0.9
            assert masks[arm][static][theirs].mean() < 0.1
    assert projection.diagnostics.merged_arms_split > 0


def test_missing_depth_and_missing_goal_degrade_gracefully(bimanual_episode_path: Path) -> None:
    class NoGoal(SimulatorSegmenter):
        def segment(self, view, prompts):  # noqa: ANN001, ANN201
            return [d for d in super().segment(view, prompts) if d.label == "robotic arm"]

    ep = read_episode(bimanual_episode_path)
    obs = KeyframeObservation.from_episode(ep, 1)
    obs.depth = obs.depth.copy()
    obs.depth[0] = 0.0  # a camera without depth
    obs.depth[1, :10] = np.nan  # a camera with a band of invalid depth
    projection = ArmProjection(NoGoal())
    grid = VoxelGrid((-0.1, -1.0, -0.2, 1.0, 1.0, 0.8), 16)
    built = ArmObservationBuilder(grid, projection).build(obs)
    for arm in ep.arm_names:
        assert np.isfinite(built[arm].voxels).all() and built[arm].voxels[0].sum() > 0
    masks = projection.masks_2d(obs)
    goal = np.isin(obs.instance, [i for i, n in enumerate(ep.instance_names) if n.startswith("button")])
    assert not masks["left"][1:][goal[1:]].any()  # the goal is not kept when it was not found
    assert projection.diagnostics.missing_depth == 2  # camera 0, once per call
    assert projection.diagnostics.no_goal_found == 2 * (len(ep.camera_names) - 1)


def test_voxel_masks_are_the_voxels_of_each_arms_kept_pixels(bimanual_episode_path: Path) -> None:
    from bimanualshift.perception.observation import arm_frames, world_point_cloud

    ep = read_episode(bimanual_episode_path)
    obs = KeyframeObservation.from_episode(ep, 1)
    grid = VoxelGrid((0.2, -0.45, -0.15, 0.9, 0.45, 0.35), 24)
    frames = arm_frames(obs)
    projection = ArmProjection(SimulatorSegmenter())
    masks3d = projection.voxel_masks(obs, grid, {arm: f.world_to_base for arm, f in frames.items()})
    masks2d = projection.masks_2d(obs)
    points, colours = world_point_cloud(obs)
    for arm, frame in frames.items():
        keep = (obs.depth > 0) & masks2d[arm]
        expected = grid.voxelize(frame.points_to_arm(points[keep]), colours[keep])[0] > 0
        assert masks3d[arm].shape == (24, 24, 24) and masks3d[arm].sum() > 50
        # Equal up to float32 rounding of points that lie on a voxel boundary.
        assert np.count_nonzero(masks3d[arm] != expected) <= max(2, 0.005 * expected.sum())
    assert not np.array_equal(masks3d["left"], masks3d["right"])


def test_each_arm_drops_clutter_in_its_goals_colours() -> None:
    """The clutter perturbation's pieces share the goal buttons' colours: each arm's mask keeps its buttons and
    none of the pieces, which a policy reading the whole scene still sees."""
    from bimanualshift.data.frames import scene_of_env
    from bimanualshift.sim.env import ManipulationEnv
    from bimanualshift.sim.perturbations import preset

    env = ManipulationEnv("push_two_buttons", image_size=64, perturbations=preset("clutter"))
    obs = KeyframeObservation.from_env(env.reset(seed=5)[0], scene_of_env(env))
    names = env.instances.names
    clutter = np.isin(obs.instance, [i for i, n in enumerate(names) if n.startswith("clutter_")])
    named = {prompt.split()[0] for prompt in env.task.goal_nouns()}
    goal = np.isin(obs.instance, [i for i, n in enumerate(names) if n.startswith("button")
                                  and named & set(env.instance_colours()[n])])
    assert clutter.sum() > 20 and goal.any()
    masks = ArmProjection(SimulatorSegmenter()).masks_2d(obs)
    for arm in ("left", "right"):
        assert not masks[arm][clutter].any()
        assert masks[arm][goal].mean() > 0.99
    env.close()
