import numpy as np
import pytest

from bimanualshift.geometry.cameras import depth_to_world_points
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.geometry.pixel_voxels import pixel_voxel_index, voxel_occupancy, voxelize_pixels, world_rays
from bimanualshift.geometry.voxels import VoxelGrid


def _cameras(n: int = 3, size: int = 24) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(1)
    k = np.array([[30.0, 0, size / 2], [0, 30.0, size / 2], [0, 0, 1]])
    extrinsics = np.stack([np.eye(4)] * n)
    for c in range(n):
        angle = rng.uniform(-0.3, 0.3)
        extrinsics[c, :3, :3] = [[np.cos(angle), 0, np.sin(angle)], [0, 1, 0], [-np.sin(angle), 0, np.cos(angle)]]
        extrinsics[c, :3, 3] = rng.normal(size=3) * 0.1
    depth = rng.uniform(0.3, 2.0, size=(n, size, size)).astype(np.float32)
    depth[0, :2] = 0.0  # no reading
    depth[1, :, :3] = np.nan  # invalid reading
    return depth, np.stack([k] * n), extrinsics


def _reference_index(depth: np.ndarray, intrinsics: np.ndarray, extrinsics: np.ndarray, grid: VoxelGrid,
                     frame: ArmFrame | None) -> np.ndarray:
    """The slow path: back-project every camera, move the points into the frame, voxelise point by point."""
    points = np.stack([depth_to_world_points(depth[c], intrinsics[c], extrinsics[c]) for c in range(len(depth))])
    if frame is not None:
        points = frame.points_to_arm(points)
    ok = np.isfinite(depth) & (depth > 0) & grid.inside(points)
    out = np.full(depth.shape, -1)
    out[ok] = np.ravel_multi_index(grid.point_to_index(points[ok]).T, (grid.size,) * 3)
    return out


@pytest.mark.parametrize("frame", [None, ArmFrame((0.2, -0.1, 0.5), yaw=2.5)])
def test_pixel_voxel_index_matches_point_by_point_voxelisation(frame: ArmFrame | None) -> None:
    depth, intrinsics, extrinsics = _cameras()
    grid = VoxelGrid((-1.0, -1.0, -0.5, 1.0, 1.0, 2.0), 16)
    transform = None if frame is None else frame.world_to_base
    index = pixel_voxel_index(depth, intrinsics, extrinsics, grid, transform)
    reference = _reference_index(depth, intrinsics, extrinsics, grid, frame)
    assert (index >= 0).sum() > 100 and (index < 0).sum() > 100  # both inside and outside cases occur
    np.testing.assert_array_equal(index, reference)
    # The rays are cached per camera pose: a second frame with other depths reuses them and stays exact.
    depth2 = depth * 0.9
    np.testing.assert_array_equal(pixel_voxel_index(depth2, intrinsics, extrinsics, grid, transform),
                                  _reference_index(depth2, intrinsics, extrinsics, grid, frame))


def test_world_rays_back_project_like_the_pinhole_model() -> None:
    depth, intrinsics, extrinsics = _cameras()
    rays, origins = world_rays(intrinsics, extrinsics, *depth.shape[1:])
    for c in range(len(depth)):
        expected = depth_to_world_points(depth[c], intrinsics[c], extrinsics[c])
        got = origins[:, c, 0, 0] + depth[c][..., None] * np.moveaxis(rays[:, c], 0, -1)
        np.testing.assert_allclose(got, expected, atol=1e-5)


def test_voxelize_pixels_and_occupancy_match_the_point_cloud_path() -> None:
    depth, intrinsics, extrinsics = _cameras()
    grid = VoxelGrid((-1.0, -1.0, -0.5, 1.0, 1.0, 2.0), 16)
    rgb = np.random.default_rng(2).integers(0, 256, size=(*depth.shape, 3), dtype=np.uint8)
    index = pixel_voxel_index(depth, intrinsics, extrinsics, grid)
    points = np.stack([depth_to_world_points(depth[c], intrinsics[c], extrinsics[c]) for c in range(len(depth))])
    valid = np.isfinite(depth) & (depth > 0)
    expected = grid.voxelize(points[valid], rgb[valid] / 255.0)
    np.testing.assert_allclose(voxelize_pixels(index, rgb, grid.size), expected, atol=1e-5)
    keep = np.zeros(depth.shape, dtype=bool)
    keep[:, 5:15, 8:20] = True
    occupancy = voxel_occupancy(index, keep, grid.size)
    np.testing.assert_array_equal(occupancy, grid.voxelize(points[valid & keep], rgb[valid & keep] / 255.0)[0] > 0)


def test_shape_mismatches_are_reported_clearly() -> None:
    depth, intrinsics, extrinsics = _cameras()
    grid = VoxelGrid((-1.0, -1.0, -0.5, 1.0, 1.0, 2.0), 16)
    with pytest.raises(ValueError, match=r"intrinsics \(C, 3, 3\)"):
        pixel_voxel_index(depth, intrinsics[:2], extrinsics, grid)
    index = pixel_voxel_index(depth, intrinsics, extrinsics, grid)
    with pytest.raises(ValueError, match="pixel mask has shape"):
        voxel_occupancy(index, np.ones((1, 2, 2), bool), grid.size)
    with pytest.raises(ValueError, match="colours have shape"):
        voxelize_pixels(index, np.zeros((2, 2, 3), np.uint8), grid.size)
