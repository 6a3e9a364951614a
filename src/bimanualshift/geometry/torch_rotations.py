"""Differentiable rotation conversions in torch (quaternions x y z w, as everywhere in this package)."""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F

from bimanualshift.geometry.frames import GRIPPER_DOWN_QUAT


def quat_to_matrix(quat: torch.Tensor) -> torch.Tensor:
    """(..., 4) x y z w -> (..., 3, 3)."""
    x, y, z, w = F.normalize(quat, dim=-1).unbind(-1)
    return torch.stack([
        1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
        2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
        2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y),
    ], dim=-1).reshape(*quat.shape[:-1], 3, 3)


def matrix_to_quat(matrix: torch.Tensor) -> torch.Tensor:
    """(..., 3, 3) -> (..., 4) x y z w with w >= 0 (the numerically stable branch per element)."""
    m = matrix
    m00, m11, m22 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    candidates = torch.stack([
        torch.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1],
                     1 + m00 + m11 + m22], -1),
        torch.stack([1 + m00 - m11 - m22, m[..., 0, 1] + m[..., 1, 0], m[..., 0, 2] + m[..., 2, 0],
                     m[..., 2, 1] - m[..., 1, 2]], -1),
        torch.stack([m[..., 0, 1] + m[..., 1, 0], 1 - m00 + m11 - m22, m[..., 1, 2] + m[..., 2, 1],
                     m[..., 0, 2] - m[..., 2, 0]], -1),
        torch.stack([m[..., 0, 2] + m[..., 2, 0], m[..., 1, 2] + m[..., 2, 1], 1 - m00 - m11 + m22,
                     m[..., 1, 0] - m[..., 0, 1]], -1),
    ], dim=-2)  # (..., 4, 4): row i is 4 * q_i * q scaled; pick the row with the largest diagonal term
    diag = torch.stack([1 + m00 + m11 + m22, 1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22], -1)
    best = diag.argmax(-1, keepdim=True)
    q = candidates.gather(-2, best[..., None].expand(*best.shape[:-1], 1, 4)).squeeze(-2)
    q = F.normalize(q, dim=-1)
    return torch.where(q[..., 3:4] < 0, -q, q)


def rotation_6d_to_matrix(d6: torch.Tensor) -> torch.Tensor:
    """(..., 6) first two matrix columns -> (..., 3, 3) by Gram-Schmidt (Zhou et al., 2019)."""
    a1, a2 = d6[..., :3], d6[..., 3:]
    b1 = F.normalize(a1, dim=-1)
    b2 = F.normalize(a2 - (b1 * a2).sum(-1, keepdim=True) * b1, dim=-1)
    b3 = torch.cross(b1, b2, dim=-1)
    return torch.stack([b1, b2, b3], dim=-1)


def quat_toward(quat: torch.Tensor, pole: np.ndarray = GRIPPER_DOWN_QUAT) -> torch.Tensor:
    """(..., 4) q or -q, whichever lies on ``pole``'s side (x y z w; default the gripper pointing down)."""
    pole_t = torch.as_tensor(pole, dtype=quat.dtype, device=quat.device)
    return torch.where((quat * pole_t).sum(-1, keepdim=True) < 0, -quat, quat)
