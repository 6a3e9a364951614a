"""Each arm's point cloud: the pixels its voxels are made of, in its own frame."""

from __future__ import annotations

import numpy as np
import pytest

from bimanualshift.data.frames import KeyframeObservation, scene_of_env
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.observation import DEFAULT_ARM_BOUNDS, ArmObservationBuilder
from bimanualshift.perception.projection import ArmProjection
from bimanualshift.perception.segmenters import make_segmenter
from bimanualshift.sim.env import ManipulationEnv


def test_points_are_the_voxels_pixels_in_the_arm_frame() -> None:
    env = ManipulationEnv("push_two_buttons", image_size=48)
    obs, _ = env.reset(seed=3)
    frame = KeyframeObservation.from_env(obs, scene_of_env(env))
    env.close()
    grid = VoxelGrid(DEFAULT_ARM_BOUNDS, 32)
    full = ArmObservationBuilder(grid, points=100_000).build(frame)
    masked = ArmObservationBuilder(grid, ArmProjection(make_segmenter("simulator")), points=100_000).build(frame)
    capped = ArmObservationBuilder(grid, points=50).build(frame)
    cloud_only = ArmObservationBuilder(grid, ArmProjection(make_segmenter("simulator")), points=100_000,
                                       voxels=False).build(frame)
    assert ArmObservationBuilder(grid).build(frame)["left"].points is None
    for arm in ("left", "right"):
        points = full[arm].points
        assert points.shape[1] == 6 and len(points) > 100
        assert np.all(points[:, :3] >= grid.lower - 1e-4) and np.all(points[:, :3] <= grid.upper + 1e-4)
        assert np.all((points[:, 3:] >= 0) & (points[:, 3:] <= 1))
        # every point's voxel is occupied, in the unmasked and in the masked observation alike
        for obs_arm in (full[arm], masked[arm]):
            idx = grid.point_to_index(obs_arm.points[:, :3])
            assert np.all(obs_arm.voxels[0][tuple(idx.T)] > 0)
        assert 0 < len(masked[arm].points) < len(points)  # the projection removes the other arm's pixels
        assert len(capped[arm].points) == 50
        # a cloud prior's builder skips the voxels and keeps the very same (masked) cloud
        assert cloud_only[arm].voxels is None
        np.testing.assert_array_equal(cloud_only[arm].points, masked[arm].points)
    assert not np.allclose(full["left"].points[:10, :3], full["right"].points[:10, :3])  # two frames


def test_a_builder_without_voxels_must_keep_points() -> None:
    with pytest.raises(ValueError, match="must keep points"):
        ArmObservationBuilder(VoxelGrid(DEFAULT_ARM_BOUNDS, 32), voxels=False)
