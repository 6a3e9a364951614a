"""Configuration of the Diffusion Policy prior (CPU-sized defaults)."""

from __future__ import annotations

from dataclasses import dataclass

from bimanualshift.priors.chunk_actions import PointCloudChunkConfig


@dataclass
class DiffusionConfig(PointCloudChunkConfig):
    # Denoiser: a transformer over the action chunk, cross-attending to the observation tokens.
    dim: int = 128
    layers: int = 3
    heads: int = 4
    train_timesteps: int = 100  # DDPM noise levels
    inference_steps: int = 10  # DDIM steps at inference
    prediction_type: str = "sample"  # the denoiser predicts the clean chunk (as DP3 does) or "epsilon", the noise
    sample_seed: int = 0  # the initial noise of inference is seeded: predictions are deterministic
