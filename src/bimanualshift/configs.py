"""Named configurations. ``debug`` is tiny: it trains in seconds on a CPU and is what the tests use."""

from __future__ import annotations

from typing import Any

PRIOR_MODELS: dict[str, dict[str, Any]] = {
    "default": {},  # PerActConfig defaults: 32^3 voxels, 96-wide tokens, 32 latents, 2 layers
    "debug": {"voxel_size": 16, "patch_size": 4, "dim": 32, "num_latents": 8, "self_attention_layers": 1, "heads": 2},
}
