"""Scene augmentations that keep voxels and actions consistent.

* ``shift_voxels``: whole-voxel translations, no resampling (the scene and the target move by the same integer
  number of voxels);
* ``Se3Augmentation`` with ``transform_voxels`` / ``transform_points`` / ``transform_quats``: a random yaw
  about the grid's vertical centre axis plus a horizontal translation, the voxels resampled and the actions and
  proprioception moved with them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
import torch.nn.functional as F

from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.goal_geometry import BOX_GEOMETRY_DIM, EXTREMITY_DIM, UNION_GEOMETRY_DIM


def shift_voxels(voxels: torch.Tensor, shift: tuple[int, int, int]) -> torch.Tensor:
    """Translate a (C, S, S, S) grid by whole voxels; cells shifted in from outside are empty."""
    out = torch.zeros_like(voxels)
    src, dst = [], []
    for d in shift:
        n = voxels.shape[1]
        if d >= 0:
            src.append(slice(0, n - d))
            dst.append(slice(d, n))
        else:
            src.append(slice(-d, n))
            dst.append(slice(0, n + d))
    out[:, dst[0], dst[1], dst[2]] = voxels[:, src[0], src[1], src[2]]
    return out


def random_shift(generator: torch.Generator, max_voxels: int) -> tuple[int, int, int]:
    s = torch.randint(-max_voxels, max_voxels + 1, (3,), generator=generator)
    return int(s[0]), int(s[1]), 0  # no vertical shift: the table stays where the prior expects it


@dataclass(frozen=True)
class Se3Augmentation:
    """Random rigid motion of the whole scene about the grid's vertical centre axis: a yaw of up to
    ``max_yaw_deg`` and a horizontal translation of up to ``max_translation_m`` (PerAct's augmentation, kept
    horizontal so the table stays where the prior expects it). Voxels are resampled (nearest neighbour, so
    occupancy stays binary and colours exact); actions and proprioception move with the scene."""

    max_translation_m: float = 0.04
    max_yaw_deg: float = 15.0

    def sample(self, generator: torch.Generator, batch: int) -> tuple[torch.Tensor, torch.Tensor]:
        """Per sample a yaw (B,) in radians and a translation (B, 3) in metres."""
        u = torch.rand(batch, 3, generator=generator) * 2 - 1
        yaw = u[:, 0] * math.radians(self.max_yaw_deg)
        translation = torch.zeros(batch, 3)
        translation[:, :2] = u[:, 1:] * self.max_translation_m
        return yaw, translation


def yaw_matrix(yaw: torch.Tensor) -> torch.Tensor:
    c, s = torch.cos(yaw), torch.sin(yaw)
    zero, one = torch.zeros_like(yaw), torch.ones_like(yaw)
    return torch.stack([c, -s, zero, s, c, zero, zero, zero, one], dim=-1).reshape(*yaw.shape, 3, 3)


def transform_points(points: torch.Tensor, grid: VoxelGrid, yaw: torch.Tensor, translation: torch.Tensor
                     ) -> torch.Tensor:
    """Points (B, ..., 3) moved by the per-sample motion: p' = R (p - c) + c + t, c the grid centre."""
    centre = torch.as_tensor((grid.lower + grid.upper) / 2, dtype=points.dtype)
    rot = yaw_matrix(yaw).to(points.dtype)
    shape = (points.shape[0],) + (1,) * (points.dim() - 2) + (3,)
    moved = torch.einsum("bij,b...j->b...i", rot, points - centre)
    return moved + centre + translation.to(points.dtype).reshape(shape)


def transform_quats(quat: torch.Tensor, yaw: torch.Tensor) -> torch.Tensor:
    """Orientations (B, ..., 4) x y z w turned by the per-sample yaw (world-aligned: q' = Rz(yaw) * q)."""
    half = yaw / 2
    qz = torch.stack([torch.zeros_like(half), torch.zeros_like(half), torch.sin(half), torch.cos(half)], dim=-1)
    qz = qz.reshape((quat.shape[0],) + (1,) * (quat.dim() - 2) + (4,)).expand_as(quat)
    x1, y1, z1, w1 = qz.unbind(-1)
    x2, y2, z2, w2 = quat.unbind(-1)
    out = torch.stack([w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                       w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2], dim=-1)
    return torch.where(out[..., 3:4] < 0, -out, out)


def transform_voxels(voxels: torch.Tensor, grid: VoxelGrid, yaw: torch.Tensor, translation: torch.Tensor
                     ) -> torch.Tensor:
    """Resample (B, C, S, S, S) grids indexed [x, y, z] so that their content moves by the per-sample motion."""
    half = torch.as_tensor((grid.upper - grid.lower) / 2, dtype=torch.float32)
    rot_t = yaw_matrix(yaw).transpose(-1, -2)
    # Output voxel at normalised n_out reads input n_in = H^-1 R^T (H n_out - t), H = diag(half extents).
    a = rot_t * half[None, None, :] / half[None, :, None]
    b = -torch.einsum("bij,bj->bi", rot_t, translation.float()) / half
    # affine_grid orders coordinates (W, H, D) = our (z, y, x): reverse both axes of the map.
    theta = torch.cat([a.flip(1).flip(2), b.flip(1)[..., None]], dim=-1)
    sample_grid = F.affine_grid(theta, list(voxels.shape), align_corners=False)
    return F.grid_sample(voxels.float(), sample_grid, mode="nearest", padding_mode="zeros", align_corners=False)


def sample_motion(augmentation: Se3Augmentation, generator: torch.Generator, targets: torch.Tensor, grid: VoxelGrid
                  ) -> tuple[torch.Tensor, torch.Tensor]:
    """Per sample a random motion (yaw (B,), translation (B, 3)); the identity for samples whose ``targets``
    (B, ..., 3) it would move out of the grid."""
    yaw, translation = augmentation.sample(generator, len(targets))
    moved = transform_points(targets, grid, yaw, translation)
    lower, upper = torch.as_tensor(grid.lower, dtype=moved.dtype), torch.as_tensor(grid.upper, dtype=moved.dtype)
    inside = ((moved >= lower) & (moved < upper)).flatten(1, -2).all(-1).all(-1)
    return yaw * inside, translation * inside[:, None]


def transform_scene(scene: torch.Tensor, grid: VoxelGrid, yaw: torch.Tensor, translation: torch.Tensor
                    ) -> torch.Tensor:
    """A scene moved by the per-sample motion: voxels (B, 4, S, S, S) resampled, or a cloud (B, P, 6) whose points
    move and whose colours stay."""
    if scene.dim() == 3:
        return torch.cat([transform_points(scene[..., :3], grid, yaw, translation), scene[..., 3:]], -1)
    return transform_voxels(scene, grid, yaw, translation)


def transform_poses(poses: torch.Tensor, grid: VoxelGrid, yaw: torch.Tensor, translation: torch.Tensor,
                    starts: tuple[int, ...] = (0,)) -> torch.Tensor:
    """Rows (B, W) holding a position and an x y z w quaternion at each of ``starts`` (proprioception: the own
    arm's pose at 0, the other arm's further on), those poses moved by the per-sample motion."""
    out = poses.clone()
    for start in starts:
        out[:, start:start + 3] = transform_points(poses[:, start:start + 3], grid, yaw, translation)
        out[:, start + 3:start + 7] = transform_quats(poses[:, start + 3:start + 7], yaw)
    return out


def _transform_box(box: torch.Tensor, grid: VoxelGrid, yaw: torch.Tensor, translation: torch.Tensor) -> torch.Tensor:
    """(B, 10) boxes (centroid, 5th / 95th percentile corners, seen flag) of the moved scene: the centroid moves
    exactly, the corners become the axis-aligned bounds of the moved box (exact for a pure translation, a little
    wider under yaw); unseen boxes stay all zeros."""
    out = box.clone()
    out[:, 0:3] = transform_points(box[:, 0:3], grid, yaw, translation)
    low, high = box[:, 3:6], box[:, 6:9]
    pick = torch.tensor([[(i >> a) & 1 for a in range(3)] for i in range(8)], dtype=torch.bool)  # (8, 3)
    corners = torch.where(pick[None], high[:, None], low[:, None])  # (B, 8, 3)
    moved = transform_points(corners, grid, yaw, translation)
    out[:, 3:6], out[:, 6:9] = moved.min(1).values, moved.max(1).values
    return torch.where(box[:, 9:10] > 0, out, box)


def transform_goal_geometry(goal: torch.Tensor, grid: VoxelGrid, yaw: torch.Tensor, translation: torch.Tensor
                            ) -> torch.Tensor:
    """(B, 10, 22 or 52) goal geometry (``perception.goal_geometry``: the union's box, then each extremity's tip and
    direction, then each goal object's box) of the moved scene. Boxes move as ``_transform_box``; the tips move
    exactly and the directions turn with the yaw. The extremities keep their order (which end is this arm's does
    not change under a few centimetres' shift). Unseen goals stay all zeros."""
    out = goal.clone()
    seen = goal[:, 9] > 0
    out[:, :BOX_GEOMETRY_DIM] = _transform_box(goal[:, :BOX_GEOMETRY_DIM], grid, yaw, translation)
    if goal.shape[1] > BOX_GEOMETRY_DIM:
        turn = yaw_matrix(yaw).to(goal.dtype)
        for start in (BOX_GEOMETRY_DIM, BOX_GEOMETRY_DIM + EXTREMITY_DIM // 2):  # each end: tip (a point), direction
            end = torch.where(seen[:, None], torch.cat([
                transform_points(goal[:, start:start + 3], grid, yaw, translation),
                torch.einsum("bij,bj->bi", turn, goal[:, start + 3:start + 6])], 1), goal[:, start:start + 6])
            out[:, start:start + 6] = end
    for start in range(UNION_GEOMETRY_DIM, goal.shape[1], BOX_GEOMETRY_DIM):  # each goal object's own box
        out[:, start:start + BOX_GEOMETRY_DIM] = _transform_box(goal[:, start:start + BOX_GEOMETRY_DIM], grid, yaw,
                                                                translation)
    return out
