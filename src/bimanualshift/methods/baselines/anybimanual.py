"""Baseline: an AnyBimanual-style transfer of the single-arm prior, with its backbone fine-tuned.

AnyBimanual also starts from a unimanual policy, but it *fine-tunes* the backbone and learns what each arm
should see and be told: a soft voxel mask per arm (a small 3-D conv net over the global scene, conditioned on
the arm and the instruction; sigmoid output multiplying the voxels) and a skill-weighted language embedding
(the instruction plus a gated, softmax-weighted sum of skill-verb embeddings). Proprioception holds the other
arm's pose and the acting arm's one-hot, as in the from-scratch baseline. Everything starts as the prior: the
mask starts near one, the skill gate at zero and the new proprio weights at zero.

The contrast with BimanualShift: a learned soft mask instead of the calibrated geometric projection, and a
fine-tuned backbone instead of a frozen prior with a residual.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import torch
from torch import nn

from bimanualshift.encoders.text import TextEncoder, default_text_encoder
from bimanualshift.geometry.voxels import VOXEL_CHANNELS
from bimanualshift.methods.baselines.from_scratch import ARMS, EXTRA_PROPRIO, ScratchVoxelPolicy, sample_extras
from bimanualshift.methods.baselines.network_spec import OWN_PROPRIO, VoxelNetworkSpec, widen_from_prior
from bimanualshift.priors.base import UnimanualPrior, register_prior
from bimanualshift.priors.peract.configuration_peract import PerActConfig
from bimanualshift.priors.peract.modeling_peract import PerActPrior
from bimanualshift.residual.skills import DEFAULT_SKILL_VERBS

ONEHOT_START = OWN_PROPRIO + 8  # the arm one-hot follows the arm's own and the other arm's proprio


@dataclass
class AnyBimanualConfig(PerActConfig):
    num_skills: int = len(DEFAULT_SKILL_VERBS)
    mask_hidden: int = 8
    mask_init: float = 4.0  # initial mask logit: sigmoid(4) = 0.98, the scene nearly unchanged


@register_prior("anybimanual")
class AnyBimanualNetwork(PerActPrior):
    config_class = AnyBimanualConfig

    def __init__(self, config: AnyBimanualConfig) -> None:
        super().__init__(config)
        c = config
        self.mask_conv = nn.Sequential(nn.Conv3d(VOXEL_CHANNELS + 3, c.mask_hidden, 3, padding=1), nn.GELU())
        self.mask_film = nn.Linear(len(ARMS) + c.text_dim, 2 * c.mask_hidden)
        self.mask_out = nn.Conv3d(c.mask_hidden, 1, 1)
        nn.init.zeros_(self.mask_out.weight)
        nn.init.constant_(self.mask_out.bias, c.mask_init)
        self.skills = nn.Parameter(torch.zeros(c.num_skills, c.text_dim))  # set from verb embeddings
        self.skill_weights = nn.Linear(c.text_dim, c.num_skills)
        self.skill_gate = nn.Parameter(torch.zeros(()))

    def soft_mask(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor) -> torch.Tensor:
        """(B, 1, S, S, S) in (0, 1): how much of each voxel the acting arm sees."""
        b = voxels.shape[0]
        hidden = self.mask_conv(torch.cat([voxels, self.coords.expand(b, -1, -1, -1, -1)], dim=1))
        arm = proprio[:, ONEHOT_START:ONEHOT_START + len(ARMS)]
        gamma, beta = self.mask_film(torch.cat([arm, text], dim=-1)).reshape(b, 2, -1, 1, 1, 1).unbind(1)
        return torch.sigmoid(self.mask_out(hidden * (1 + gamma) + beta))

    def skill_language(self, text: torch.Tensor) -> torch.Tensor:
        weights = self.skill_weights(text).softmax(-1)
        return text + self.skill_gate * (weights @ self.skills)

    def forward(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor, keep_maps: bool = False
                ) -> dict[str, torch.Tensor]:
        voxels = voxels * self.soft_mask(voxels, proprio, text)
        return super().forward(voxels, proprio, self.skill_language(text), keep_maps)


def build_anybimanual(prior: UnimanualPrior | None, extra_dim: int, size: str,
                      text_encoder: TextEncoder | None = None) -> AnyBimanualNetwork:
    if prior is None or prior.config.type != "peract":
        raise ValueError("the AnyBimanual-style baseline starts from a PerAct-style single-arm prior")
    config = AnyBimanualConfig(**{**asdict(prior.config), "proprio_dim": OWN_PROPRIO + extra_dim})
    model = AnyBimanualNetwork(config)
    widen_from_prior(model, prior, extra_dim)
    encoder = text_encoder or default_text_encoder()
    with torch.no_grad():
        model.skills.copy_(torch.as_tensor(np.asarray(encoder.encode(list(DEFAULT_SKILL_VERBS)), np.float32)))
    return model


SPEC = VoxelNetworkSpec("anybimanual", arms=ARMS, extra_dim=EXTRA_PROPRIO, extra_proprio=sample_extras,
                        extra_poses=(0,), init_from_prior=True, build=build_anybimanual)


class AnyBimanualPolicy(ScratchVoxelPolicy):
    """Acts like the from-scratch policy (one network, both arms, the same proprioception); the mask and the
    skill-weighted language live inside the network."""

    name = "anybimanual"
