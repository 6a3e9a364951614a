"""SE(3) augmentation restricted to whole-voxel translations, which keep voxels and actions consistent
without resampling the grid: the scene and the target move by the same integer number of voxels."""

from __future__ import annotations

import torch


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
