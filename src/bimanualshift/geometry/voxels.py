"""Fusion of coloured point clouds into a dense voxel grid.

A voxel grid has ``size`` cells per side over axis-aligned ``bounds`` (xmin, ymin, zmin, xmax, ymax,
zmax), expressed in whatever frame the points are in (world or an arm's base frame). Each cell holds
the mean RGB of the points that fall in it and an occupancy flag: 4 channels, ``(4, S, S, S)``,
indexed ``[channel, x, y, z]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

VOXEL_CHANNELS = 4  # occupancy, r, g, b


@dataclass(frozen=True)
class VoxelGrid:
    bounds: tuple[float, float, float, float, float, float]
    size: int

    def __post_init__(self) -> None:
        lo, hi = np.array(self.bounds[:3]), np.array(self.bounds[3:])
        if len(self.bounds) != 6 or np.any(hi <= lo):
            raise ValueError(f"bounds must be (xmin, ymin, zmin, xmax, ymax, zmax) with max > min, got {self.bounds}")
        if self.size < 2:
            raise ValueError(f"voxel grid size must be >= 2, got {self.size}")

    @property
    def lower(self) -> np.ndarray:
        return np.asarray(self.bounds[:3], dtype=np.float32)

    @property
    def upper(self) -> np.ndarray:
        return np.asarray(self.bounds[3:], dtype=np.float32)

    @property
    def voxel_size(self) -> np.ndarray:
        return (self.upper - self.lower) / self.size

    def point_to_index(self, points: np.ndarray) -> np.ndarray:
        """Integer voxel index (..., 3) of each point, clipped into the grid."""
        idx = np.floor((np.asarray(points, dtype=np.float32) - self.lower) / self.voxel_size).astype(np.int64)
        return np.clip(idx, 0, self.size - 1)

    def index_to_point(self, index: np.ndarray) -> np.ndarray:
        """Centre (..., 3) of voxel ``index``."""
        return self.lower + (np.asarray(index, dtype=np.float32) + 0.5) * self.voxel_size

    def inside(self, points: np.ndarray) -> np.ndarray:
        return np.all((points >= self.lower) & (points < self.upper), axis=-1)

    def voxelize(self, points: np.ndarray, colors: np.ndarray) -> np.ndarray:
        """Fuse points (N, 3) with colours (N, 3) in [0, 1] into a (4, S, S, S) float32 grid."""
        points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
        colors = np.asarray(colors, dtype=np.float32).reshape(-1, 3)
        if len(points) != len(colors):
            raise ValueError(f"got {len(points)} points but {len(colors)} colours")
        keep = self.inside(points) & np.isfinite(points).all(axis=-1)
        points, colors = points[keep], colors[keep]
        s = self.size
        grid = np.zeros((VOXEL_CHANNELS, s * s * s), dtype=np.float32)
        if len(points):
            idx = self.point_to_index(points)
            flat = (idx[:, 0] * s + idx[:, 1]) * s + idx[:, 2]
            counts = np.bincount(flat, minlength=s**3).astype(np.float32)
            occupied = counts > 0
            grid[0] = occupied
            for c in range(3):
                sums = np.bincount(flat, weights=colors[:, c], minlength=s**3)
                grid[1 + c, occupied] = sums[occupied] / counts[occupied]
        return grid.reshape(VOXEL_CHANNELS, s, s, s)

