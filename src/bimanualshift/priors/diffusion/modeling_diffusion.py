"""A Diffusion Policy prior: point cloud + proprioception + language -> a chunk of keyframe actions.

The observation encoder reads the arm's voxel grid (already projected by the arm-conditioned projection when it
serves a bimanual robot) as a coloured point cloud of occupied voxels and encodes it with a PointNet (shared MLP,
max-pooled per spatial cell). A transformer denoiser cross-attends to those cell tokens, the instruction and the
proprioception and denoises a normalised action chunk (position, 6-D rotation, gripper, collision flag per
keyframe). Training is DDPM (predicting the clean chunk by default, as DP3 does, or the noise), inference a few
DDIM steps from seeded noise; both schedulers come from ``diffusers``.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from diffusers import DDIMScheduler, DDPMScheduler
from torch import nn

from bimanualshift.priors.base import PriorOutput, register_prior
from bimanualshift.priors.chunk_actions import (
    PointCloudChunkPrior,
    chunk_output_fields,
    register_action_range,
)
from bimanualshift.priors.diffusion.configuration_diffusion import DiffusionConfig


def sinusoidal_embedding(t: torch.Tensor, dim: int) -> torch.Tensor:
    half = dim // 2
    freqs = torch.exp(-math.log(10000.0) * torch.arange(half, dtype=torch.float32) / half)
    angles = t.float()[:, None] * freqs[None]
    return torch.cat([angles.sin(), angles.cos()], dim=-1)


@register_prior("diffusion")
class DiffusionPrior(PointCloudChunkPrior):
    config_class = DiffusionConfig

    def __init__(self, config: DiffusionConfig) -> None:
        if config.prediction_type not in ("sample", "epsilon"):
            raise ValueError(f"prediction_type must be 'sample' or 'epsilon', got {config.prediction_type!r}")
        super().__init__(config, config.dim)
        c = config
        self.time_mlp = nn.Sequential(nn.Linear(c.dim, c.dim), nn.GELU(), nn.Linear(c.dim, c.dim))
        self.action_in = nn.Linear(c.action_dim, c.dim)
        self.action_pos = nn.Parameter(torch.randn(1, c.horizon, c.dim) * 0.02)
        layer = nn.TransformerDecoderLayer(c.dim, c.heads, 2 * c.dim, dropout=0.0, batch_first=True, norm_first=True)
        self.denoiser = nn.TransformerDecoder(layer, c.layers)
        self.action_out = nn.Sequential(nn.LayerNorm(c.dim), nn.Linear(c.dim, c.action_dim))
        # Normalisation of actions to [-1, 1]; set from the training data by `set_normalization`.
        register_action_range(self, self.grid)
        schedule = {"num_train_timesteps": c.train_timesteps, "beta_schedule": "squaredcos_cap_v2",
                    "clip_sample": True, "prediction_type": c.prediction_type}
        self.train_scheduler = DDPMScheduler(**schedule)
        self.sample_scheduler = DDIMScheduler(**schedule)

    # -- networks ----------------------------------------------------------------------------------------------
    def encode_observation(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor
                    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Observation tokens (B, cells^3 + 2, dim) for the denoiser and the visual features (B, point_dim)."""
        cells, feature = self.points(voxels.float())
        tokens = torch.cat([self.obs_tokens["points"](cells), self.obs_tokens["proprio"](proprio)[:, None],
                            self.obs_tokens["text"](text)[:, None]], dim=1)
        return tokens, feature

    def denoise(self, noisy: torch.Tensor, t: torch.Tensor, tokens: torch.Tensor) -> torch.Tensor:
        time = self.time_mlp(sinusoidal_embedding(t, self.config.dim))[:, None]
        x = self.action_in(noisy) + self.action_pos + time
        return self.action_out(self.denoiser(x, torch.cat([time, tokens], dim=1)))

    def compute_loss(self, inputs: tuple[torch.Tensor, ...], actions: dict[str, torch.Tensor],
                     generator: torch.Generator | None = None) -> dict[str, torch.Tensor]:
        """DDPM loss on the normalised action chunk: the error of the predicted clean chunk or noise."""
        clean = self.encode_actions(actions["position"], actions["quat"], actions["gripper_open"],
                                    actions["ignore_collisions"])
        tokens, _ = self.encode_observation(*inputs)
        b = clean.shape[0]
        noise = torch.randn(clean.shape, generator=generator)
        t = torch.randint(0, self.config.train_timesteps, (b,), generator=generator)
        noisy = self.train_scheduler.add_noise(clean, noise, t)
        target = clean if self.config.prediction_type == "sample" else noise
        loss = F.mse_loss(self.denoise(noisy, t, tokens), target)
        return {"diffusion": loss, "total": loss}

    @torch.no_grad()
    def sample(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor
               ) -> tuple[torch.Tensor, torch.Tensor]:
        """DDIM sampling of the normalised chunk (B, H, action_dim) and the visual features."""
        c = self.config
        tokens, feature = self.encode_observation(voxels, proprio, text)
        generator = torch.Generator().manual_seed(c.sample_seed)
        x = torch.randn((voxels.shape[0], c.horizon, c.action_dim), generator=generator)
        scheduler = self.sample_scheduler
        scheduler.set_timesteps(c.inference_steps)
        for t in scheduler.timesteps:
            eps = self.denoise(x, t.expand(x.shape[0]), tokens)
            x = scheduler.step(eps, t, x, eta=0.0).prev_sample
        return x, feature

    @torch.no_grad()
    def predict(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor) -> PriorOutput:
        x, feature = self.sample(voxels, proprio, text)
        return PriorOutput(features=feature, **chunk_output_fields(self.decode_actions(x)))
