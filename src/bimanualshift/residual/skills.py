"""The skill basis Z (Eq. 5): N learnable vectors initialised from text embeddings of action verbs."""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from bimanualshift.encoders.text import TextEncoder

DEFAULT_SKILL_VERBS = (
    "reach", "grasp", "lift", "push", "press", "pull", "place", "release",
    "rotate", "slide", "insert", "hold", "sweep", "open", "close", "align",
)


class SkillBasis(nn.Module):
    def __init__(self, num_skills: int, dim: int) -> None:
        super().__init__()
        self.z = nn.Parameter(torch.randn(num_skills, dim) / dim**0.5)

    @staticmethod
    def from_verbs(encoder: TextEncoder, verbs: tuple[str, ...] = DEFAULT_SKILL_VERBS) -> SkillBasis:
        basis = SkillBasis(len(verbs), encoder.dim)
        with torch.no_grad():
            basis.z.copy_(torch.as_tensor(np.asarray(encoder.encode(list(verbs)), dtype=np.float32)))
        return basis

    def combine(self, weights: torch.Tensor, compensation: torch.Tensor) -> torch.Tensor:
        """Eq. 7: v = sum_i w_i z_i + h."""
        return weights @ self.z + compensation
