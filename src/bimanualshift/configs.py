"""Named model sizes per prior type. ``debug`` is tiny: it trains in seconds on a CPU and is what the tests use."""

from __future__ import annotations

from typing import Any

PRIOR_SIZES: dict[str, dict[str, dict[str, Any]]] = {
    "peract": {
        "default": {},  # PerActConfig defaults: 32^3 voxels, 96-wide tokens, 32 latents, 2 layers
        "paper": {"voxel_size": 100, "patch_size": 5, "dim": 128, "num_latents": 64, "self_attention_layers": 4},
        "debug": {"voxel_size": 16, "patch_size": 4, "dim": 32, "num_latents": 8, "self_attention_layers": 1,
                  "heads": 2},
    },
    "diffusion": {
        "default": {},  # DiffusionConfig defaults: 32^3 voxels, 1024 points, 3 layers of width 128
        "debug": {"voxel_size": 16, "max_points": 128, "point_dim": 32, "cells": 2, "dim": 32, "layers": 1, "heads": 2,
                  "train_timesteps": 20, "inference_steps": 3},
    },
    "rvt": {
        "default": {},  # RVTConfig defaults: 32,768 points, 3 views of 48^2, 4 layers of width 96 per stage
        "debug": {"voxel_size": 16, "num_points": 256, "image_size": 16, "patch_size": 4, "dim": 32, "layers": 1,
                  "heads": 2, "decoder_dim": 8, "lift_grid": 8, "rotation_bin_degrees": 30.0},
    },
    "act": {
        "default": {},  # ACTConfig defaults: 32^3 voxels, 1024 points, 2 + 2 layers of width 128
        "debug": {"voxel_size": 16, "max_points": 128, "point_dim": 32, "cells": 2, "dim": 32, "encoder_layers": 1,
                  "decoder_layers": 1, "heads": 2, "latent_dim": 4},
    },
}
# Training steps of the residual branch (Manager, Z, G): with batch 4 its validation error still falls well past
# 1,500 steps on tasks the prior never saw (take_tray_out_of_oven); a step costs ~1 ms, the prior being cached.
RESIDUAL_STEPS = 10000

# The frozen prior the benchmark, `train` and the demo use unless told otherwise: the PerAct-style one, the paper's
# main backbone (its Table I rows); the RVT-style prior is the second backbone (the backbones study).
DEFAULT_PRIOR = "peract_suite_v2"

PRIOR_MODELS = PRIOR_SIZES["peract"]  # the PerAct sizes, by their historical name


def prior_model_config(prior_type: str, size: str) -> dict[str, Any]:
    """Config-field overrides of a named size; a clear error for an unknown type or size."""
    if prior_type not in PRIOR_SIZES:
        raise ValueError(f"no named sizes for prior type {prior_type!r}; known: {sorted(PRIOR_SIZES)}")
    sizes = PRIOR_SIZES[prior_type]
    if size not in sizes:
        raise ValueError(f"unknown size {size!r} for the {prior_type} prior; choose from {sorted(sizes)}")
    return dict(sizes[size])
