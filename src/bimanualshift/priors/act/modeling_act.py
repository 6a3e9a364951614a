"""ACT (Zhao et al., 2023): a conditional VAE whose decoder is a transformer that predicts a chunk of actions.

Training encodes the expert chunk and the proprioception into a style latent z (a small transformer encoder over
[CLS, proprio, actions]); the policy transformer reads the observation tokens (point-cloud cells of the voxel
grid, proprioception, instruction) and z, and one learned query per future action decodes the chunk. The loss
is the L1 error of the normalised chunk plus ``kl_weight`` times the KL of z; at inference z = 0, so a
prediction is deterministic. The benchmark trains it from scratch on bimanual demos (a baseline, not a prior).
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from bimanualshift.priors.act.configuration_act import ACTConfig
from bimanualshift.priors.base import PriorOutput, register_prior
from bimanualshift.priors.chunk_actions import (
    PointCloudChunkPrior,
    chunk_output_fields,
    decode_actions,
    encode_actions,
    register_action_range,
)


def _encoder(dim: int, heads: int, layers: int) -> nn.TransformerEncoder:
    layer = nn.TransformerEncoderLayer(dim, heads, 2 * dim, dropout=0.0, batch_first=True, norm_first=True)
    return nn.TransformerEncoder(layer, layers, enable_nested_tensor=False)


@register_prior("act")
class ACTPolicy(PointCloudChunkPrior):
    config_class = ACTConfig

    def __init__(self, config: ACTConfig) -> None:
        super().__init__(config, config.dim)
        c = config
        self.obs_tokens["latent"] = nn.Linear(c.latent_dim, c.dim)
        self.policy_encoder = _encoder(c.dim, c.heads, c.encoder_layers)
        layer = nn.TransformerDecoderLayer(c.dim, c.heads, 2 * c.dim, dropout=0.0, batch_first=True, norm_first=True)
        self.decoder = nn.TransformerDecoder(layer, c.decoder_layers)
        self.queries = nn.Parameter(torch.randn(1, c.horizon, c.dim) * 0.02)
        self.action_out = nn.Sequential(nn.LayerNorm(c.dim), nn.Linear(c.dim, c.action_dim))
        # The CVAE encoder (training only): [CLS, proprio, a_1..a_H] -> (mu, log var) of z.
        self.style_cls = nn.Parameter(torch.randn(1, 1, c.dim) * 0.02)
        self.style_inputs = nn.ModuleDict({"proprio": nn.Linear(c.proprio_dim + 1, c.dim),
                                           "action": nn.Linear(c.action_dim, c.dim)})
        self.style_pos = nn.Parameter(torch.randn(1, c.horizon + 2, c.dim) * 0.02)
        self.style_encoder = _encoder(c.dim, c.heads, 1)
        self.style_out = nn.Linear(c.dim, 2 * c.latent_dim)
        register_action_range(self, self.grid)

    def style(self, proprio: torch.Tensor, chunk: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        b = chunk.shape[0]
        x = torch.cat([self.style_cls.expand(b, -1, -1), self.style_inputs["proprio"](proprio)[:, None],
                       self.style_inputs["action"](chunk)], dim=1) + self.style_pos
        mu, log_var = self.style_out(self.style_encoder(x)[:, 0]).chunk(2, dim=-1)
        return mu, log_var

    def decode(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor, z: torch.Tensor
               ) -> tuple[torch.Tensor, torch.Tensor]:
        """The normalised chunk (B, H, action_dim) and the visual features (B, point_dim)."""
        cells, feature = self.points(voxels.float())
        tokens = torch.cat([self.obs_tokens["points"](cells), self.obs_tokens["proprio"](proprio)[:, None],
                            self.obs_tokens["text"](text)[:, None], self.obs_tokens["latent"](z)[:, None]], dim=1)
        memory = self.policy_encoder(tokens)
        out = self.decoder(self.queries.expand(voxels.shape[0], -1, -1), memory)
        return torch.tanh(self.action_out(out)), feature

    def compute_loss(self, inputs: tuple[torch.Tensor, ...], actions: dict[str, torch.Tensor],
                     generator: torch.Generator | None = None) -> dict[str, torch.Tensor]:
        voxels, proprio, text = inputs
        target = encode_actions(self.action_low, self.action_high, actions["position"], actions["quat"],
                                actions["gripper_open"], actions["ignore_collisions"])
        mu, log_var = self.style(proprio, target)
        z = mu + (0.5 * log_var).exp() * torch.randn(mu.shape, generator=generator)
        pred, _ = self.decode(voxels, proprio, text, z)
        l1 = F.l1_loss(pred, target)
        kl = (-0.5 * (1 + log_var - mu.pow(2) - log_var.exp())).sum(-1).mean()
        return {"l1": l1, "kl": kl, "total": l1 + self.config.kl_weight * kl}

    @torch.no_grad()
    def predict(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor) -> PriorOutput:
        z = torch.zeros(voxels.shape[0], self.config.latent_dim)
        x, feature = self.decode(voxels, proprio, text, z)
        return PriorOutput(features=feature, **chunk_output_fields(decode_actions(self.action_low, self.action_high,
                                                                                  x)))
