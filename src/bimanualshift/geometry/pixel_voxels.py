"""Every pixel of a set of depth cameras to its voxel in a grid, with the per-pixel rays cached per camera.

A pixel (u, v) with depth z is the world point ``t + z * d(u, v)``, where ``t`` is the camera centre and ``d``
the pixel's ray in world coordinates scaled so that its optical-axis component is 1. Composed with the affine map
from the world to continuous voxel coordinates, ``q = A p + c``, a pixel's voxel coordinate is
``(A t + c) + z * (A d(u, v))``. The scaled rays depend only on the camera's intrinsics, its pose and the grid, so
across the keyframes of an episode they are computed once and a frame costs one multiply-add per pixel and axis.

The per-pixel loops are compiled with numba (already a dependency of robosuite): one pass over the pixels
instead of a dozen full-image numpy temporaries keeps projecting six 128x128 cameras for both arms within a
few milliseconds.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit

from bimanualshift.geometry.voxels import VoxelGrid

MAX_DEPTH = 100.0  # metres; farther readings are treated as missing


def world_to_voxel_affine(grid: VoxelGrid, world_to_frame: np.ndarray | None = None
                          ) -> tuple[np.ndarray, np.ndarray]:
    """(A, c) with ``A @ p + c`` the continuous voxel coordinate of world point p in a grid whose bounds are
    expressed in the frame ``world_to_frame`` maps to (the world itself when None)."""
    transform = np.eye(4) if world_to_frame is None else np.asarray(world_to_frame, dtype=np.float64)
    scale = 1.0 / grid.voxel_size.astype(np.float64)
    return scale[:, None] * transform[:3, :3], scale * (transform[:3, 3] - grid.lower.astype(np.float64))


@lru_cache(maxsize=64)
def _voxel_rays(k_bytes: bytes, e_bytes: bytes, a_bytes: bytes, c_bytes: bytes, h: int, w: int
                ) -> tuple[np.ndarray, np.ndarray]:
    ks = np.frombuffer(k_bytes).reshape(-1, 3, 3)
    es = np.frombuffer(e_bytes).reshape(-1, 4, 4)
    a = np.frombuffer(a_bytes).reshape(3, 3)
    c = np.frombuffer(c_bytes)
    rays = np.empty((3, len(ks), h, w), dtype=np.float32)  # one contiguous plane per axis
    origins = np.empty((3, len(ks), 1, 1), dtype=np.float32)
    for cam, (k, e) in enumerate(zip(ks, es)):
        u = (np.arange(w) - k[0, 2]) / k[0, 0]
        v = (np.arange(h) - k[1, 2]) / k[1, 1]
        at_unit_depth = np.stack(np.broadcast_arrays(u[None, :], v[:, None], 1.0), axis=-1)  # (H, W, 3)
        rays[:, cam] = np.moveaxis(at_unit_depth @ (a @ e[:3, :3]).T, -1, 0)
        origins[:, cam, 0, 0] = a @ e[:3, 3] + c
    rays.flags.writeable = False
    origins.flags.writeable = False
    return rays, origins


def voxel_rays(intrinsics: np.ndarray, extrinsics: np.ndarray, affine: tuple[np.ndarray, np.ndarray], h: int, w: int
               ) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel rays (3, C, H, W) and camera origins (3, C, 1, 1) in continuous voxel coordinates, cached per
    camera set, pose and grid."""
    a, c = affine
    return _voxel_rays(np.ascontiguousarray(intrinsics, np.float64).tobytes(),
                       np.ascontiguousarray(extrinsics, np.float64).tobytes(),
                       np.ascontiguousarray(a, np.float64).tobytes(), np.ascontiguousarray(c, np.float64).tobytes(),
                       h, w)


@njit(cache=True, nogil=True)
def _index_kernel(depth: np.ndarray, rays: np.ndarray, origins: np.ndarray, size: int, max_depth: float
                  ) -> np.ndarray:  # pragma: no cover - compiled
    n_cam, h, w = depth.shape
    out = np.full((n_cam, h, w), -1, dtype=np.int32)
    for c in range(n_cam):
        for v in range(h):
            for u in range(w):
                z = depth[c, v, u]
                if not (z > 0.0 and z < max_depth):  # also rejects NaN
                    continue
                flat = 0
                inside = True
                for axis in range(3):
                    q = origins[axis, c, 0, 0] + z * rays[axis, c, v, u]
                    if not (q >= 0.0 and q < size):
                        inside = False
                        break
                    flat = flat * size + int(q)
                if inside:
                    out[c, v, u] = flat
    return out


@njit(cache=True, nogil=True)
def _occupancy_kernel(index: np.ndarray, keep: np.ndarray, size: int) -> np.ndarray:  # pragma: no cover
    hit = np.zeros(size * size * size, dtype=np.bool_)
    flat_index, flat_keep = index.ravel(), keep.ravel()
    for i in range(flat_index.size):
        if flat_keep[i] and flat_index[i] >= 0:
            hit[flat_index[i]] = True
    return hit.reshape(size, size, size)


@njit(cache=True, nogil=True)
def _voxelize_kernel(index: np.ndarray, rgb: np.ndarray, size: int) -> np.ndarray:  # pragma: no cover
    n = size * size * size
    counts = np.zeros(n, dtype=np.int32)
    sums = np.zeros((3, n), dtype=np.float32)
    flat_index = index.ravel()
    flat_rgb = rgb.reshape(-1, 3)
    for i in range(flat_index.size):
        k = flat_index[i]
        if k >= 0:
            counts[k] += 1
            for ch in range(3):
                sums[ch, k] += flat_rgb[i, ch]
    grid = np.zeros((4, n), dtype=np.float32)
    for k in range(n):
        if counts[k] > 0:
            grid[0, k] = 1.0
            for ch in range(3):
                grid[1 + ch, k] = sums[ch, k] / (255.0 * counts[k])
    return grid.reshape(4, size, size, size)


def pixel_voxel_index(depth: np.ndarray, intrinsics: np.ndarray, extrinsics: np.ndarray, grid: VoxelGrid,
                      world_to_frame: np.ndarray | None = None) -> np.ndarray:
    """Flat voxel index ``(x * S + y) * S + z`` of every pixel, shape (C, H, W) int32; -1 where the pixel has no
    depth (zero, NaN or beyond ``MAX_DEPTH``) or falls outside the grid.

    ``depth`` is (C, H, W) metres, ``intrinsics`` (C, 3, 3), ``extrinsics`` (C, 4, 4) camera-to-world.
    """
    depth = np.ascontiguousarray(depth, dtype=np.float32)
    if depth.ndim != 3 or intrinsics.shape != (len(depth), 3, 3) or extrinsics.shape != (len(depth), 4, 4):
        raise ValueError(f"expected depth (C, H, W), intrinsics (C, 3, 3) and extrinsics (C, 4, 4), got "
                         f"{depth.shape}, {intrinsics.shape} and {extrinsics.shape}")
    rays, origins = voxel_rays(intrinsics, extrinsics, world_to_voxel_affine(grid, world_to_frame), *depth.shape[1:])
    return _index_kernel(depth, rays, origins, grid.size, MAX_DEPTH)


def voxel_occupancy(index: np.ndarray, keep: np.ndarray, size: int) -> np.ndarray:
    """(S, S, S) bool: the voxels hit by at least one kept pixel (``index`` from ``pixel_voxel_index``)."""
    if index.shape != keep.shape:
        raise ValueError(f"the pixel mask has shape {keep.shape} but the voxel index {index.shape}")
    return _occupancy_kernel(np.ascontiguousarray(index, np.int32), np.ascontiguousarray(keep, np.bool_), size)


def voxelize_pixels(index: np.ndarray, rgb: np.ndarray, size: int) -> np.ndarray:
    """The (4, S, S, S) occupancy + mean-colour grid of ``VoxelGrid.voxelize`` from a pixel voxel index (C, H, W)
    and uint8 colours (C, H, W, 3), without materialising the point cloud."""
    if rgb.shape != (*index.shape, 3):
        raise ValueError(f"colours have shape {rgb.shape}; expected {(*index.shape, 3)} to match the voxel index")
    return _voxelize_kernel(np.ascontiguousarray(index, np.int32), np.ascontiguousarray(rgb, np.uint8), size)


def world_rays(intrinsics: np.ndarray, extrinsics: np.ndarray, h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel rays (3, C, H, W) and camera centres (3, C, 1, 1) in world coordinates (cached): pixel (u, v)
    of camera c with depth z is the world point ``origins[:, c, 0, 0] + z * rays[:, c, v, u]``."""
    return voxel_rays(intrinsics, extrinsics, (np.eye(3), np.zeros(3)), h, w)
