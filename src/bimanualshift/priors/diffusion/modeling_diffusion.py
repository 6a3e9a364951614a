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

from bimanualshift.geometry.voxels import VoxelGrid
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


class PointEncoder(nn.Module):
    """PointNet over the occupied voxels: (xyz in [-1, 1], rgb) -> shared MLP, then max-pooled per spatial cell.

    A single global max-pool cannot say *where* things are precisely enough for keyframe targets a few
    centimetres wide; pooling into ``cells``^3 cells of the grid keeps a coarse layout (one token per cell, with a
    learned cell embedding) that the denoiser cross-attends to. The global max over all cells is the visual
    feature the Manager reads.
    """

    def __init__(self, voxel_size: int, max_points: int, dim: int, cells: int = 4) -> None:
        super().__init__()
        self.max_points, self.cells, self.dim = max_points, max(cells, 1), dim
        coords = torch.stack(torch.meshgrid(*[torch.linspace(-1, 1, voxel_size)] * 3, indexing="ij"))
        self.register_buffer("coords", coords.flatten(1).T.contiguous(), persistent=False)  # (S^3, 3)
        cell_of = (torch.arange(voxel_size) * self.cells // voxel_size)
        cell = torch.stack(torch.meshgrid(cell_of, cell_of, cell_of, indexing="ij")).flatten(1)
        self.register_buffer("cell", (cell[0] * self.cells + cell[1]) * self.cells + cell[2], persistent=False)
        # Fixed tie-breaking noise: which voxels are kept when more than max_points are occupied is random but
        # the same on every call, so a prediction does not depend on a global RNG.
        tie = torch.rand(voxel_size**3, generator=torch.Generator().manual_seed(0))
        self.register_buffer("tie", tie, persistent=False)
        self.mlp = nn.Sequential(nn.Linear(6, dim // 2), nn.GELU(), nn.Linear(dim // 2, dim), nn.GELU(),
                                 nn.Linear(dim, dim))
        self.cell_embedding = nn.Parameter(torch.randn(self.cells**3, dim) * 0.02)

    def forward(self, voxels: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(B, 4, S, S, S) -> cell tokens (B, cells^3, dim) and the global feature (B, dim)."""
        b = voxels.shape[0]
        flat = voxels.flatten(2)  # (B, 4, S^3)
        occupied = flat[:, 0] > 0.5
        k = min(self.max_points, flat.shape[-1])
        score = occupied.float() * 2 + self.tie  # occupied first, then a fixed random order
        index = score.topk(k, dim=-1).indices  # (B, k)
        picked_occ = occupied.gather(1, index)
        xyz = self.coords[index]  # (B, k, 3)
        rgb = flat[:, 1:].gather(2, index[:, None].expand(b, 3, k)).transpose(1, 2)
        features = self.mlp(torch.cat([xyz, rgb], dim=-1))
        features = features.masked_fill(~picked_occ[..., None], float("-inf"))
        n_cells = self.cells**3
        pooled = torch.full((b, n_cells, self.dim), float("-inf"))
        cells = self.cell[index][..., None].expand(b, k, self.dim)
        pooled = pooled.scatter_reduce(1, cells, features, reduce="amax", include_self=True)
        pooled = torch.where(torch.isfinite(pooled), pooled, torch.zeros_like(pooled))  # empty cell -> 0
        global_feature = features.amax(1)
        global_feature = torch.where(torch.isfinite(global_feature), global_feature, torch.zeros_like(global_feature))
        return pooled + self.cell_embedding, global_feature


@register_prior("diffusion")
class DiffusionPrior(PointCloudChunkPrior):
    config_class = DiffusionConfig

    def __init__(self, config: DiffusionConfig) -> None:
        super().__init__(config)
        c = config
        if c.prediction_type not in ("sample", "epsilon"):
            raise ValueError(f"prediction_type must be 'sample' or 'epsilon', got {c.prediction_type!r}")
        self.grid = VoxelGrid(tuple(c.bounds), c.voxel_size)
        self.points = PointEncoder(c.voxel_size, c.max_points, c.point_dim, c.cells)
        self.obs_tokens = nn.ModuleDict({
            "points": nn.Linear(c.point_dim, c.dim),
            "proprio": nn.Linear(c.proprio_dim + 1, c.dim),
            "text": nn.Linear(c.text_dim, c.dim),
        })
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
    def observation(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor
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
        tokens, _ = self.observation(*inputs)
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
        tokens, feature = self.observation(voxels, proprio, text)
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
