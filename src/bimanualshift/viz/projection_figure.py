"""The arm-conditioned projection as a picture (the paper's Fig. 3): the voxelised scene, then what the left
and the right arm's prior sees after the projection."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bimanualshift.data.frames import KeyframeObservation  # noqa: E402
from bimanualshift.geometry.voxels import VoxelGrid  # noqa: E402
from bimanualshift.perception.observation import world_point_cloud  # noqa: E402
from bimanualshift.perception.projection import ArmProjection  # noqa: E402
from bimanualshift.perception.quality import WORLD_GRID  # noqa: E402
from bimanualshift.utils.io import atomic_writer  # noqa: E402


def occupied_voxels(points: np.ndarray, colours: np.ndarray, grid: VoxelGrid) -> tuple[np.ndarray, np.ndarray]:
    """Centres and mean colours of the voxels that hold at least one point inside the grid."""
    inside = np.all((points >= grid.lower) & (points < grid.upper), axis=-1)
    idx = grid.point_to_index(points[inside])
    flat = np.ravel_multi_index(idx.T, (grid.size,) * 3)
    keys, inverse = np.unique(flat, return_inverse=True)
    sums = np.zeros((len(keys), 3))
    np.add.at(sums, inverse, colours[inside])
    counts = np.bincount(inverse, minlength=len(keys))[:, None]
    centres = grid.index_to_point(np.stack(np.unravel_index(keys, (grid.size,) * 3), axis=-1))
    return centres, sums / counts


def projection_figure(obs: KeyframeObservation, projection: ArmProjection, path: str | Path, title: str = "",
                      grid: VoxelGrid = WORLD_GRID) -> Path:
    points, colours = world_point_cloud(obs)
    valid = np.isfinite(obs.depth) & (obs.depth > 0)
    masks = projection.masks_2d(obs)
    panels = [("voxelised scene", valid)] + [(f"{arm} arm's view after projection", valid & masks[arm])
                                             for arm in obs.scene.arm_names]
    fig = plt.figure(figsize=(5 * len(panels), 5))
    for i, (name, keep) in enumerate(panels):
        ax = fig.add_subplot(1, len(panels), i + 1, projection="3d")
        centres, rgb = occupied_voxels(points[keep], colours[keep], grid)
        ax.scatter(centres[:, 0], centres[:, 1], centres[:, 2], c=np.clip(rgb, 0, 1), s=6, marker="s", depthshade=False)
        ax.set_xlim(grid.bounds[0], grid.bounds[3])
        ax.set_ylim(grid.bounds[1], grid.bounds[4])
        ax.set_zlim(grid.bounds[2], grid.bounds[5])
        ax.set_box_aspect(np.subtract(grid.bounds[3:], grid.bounds[:3]))
        ax.view_init(elev=28, azim=-155)
        ax.set_title(f"{name}\n{len(centres)} voxels", fontsize=10)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_zticks([])
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    with atomic_writer(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
    return path
