"""Configuration of the ACT network (CPU-sized defaults)."""

from __future__ import annotations

from dataclasses import dataclass

from bimanualshift.priors.chunk_actions import PointCloudChunkConfig


@dataclass
class ACTConfig(PointCloudChunkConfig):
    # Transformer encoder over the observation tokens and the style latent, decoder with one query per action.
    dim: int = 128
    encoder_layers: int = 2
    decoder_layers: int = 2
    heads: int = 4
    latent_dim: int = 16  # the CVAE's style variable z (zero at inference)
    kl_weight: float = 10.0  # ACT's beta
