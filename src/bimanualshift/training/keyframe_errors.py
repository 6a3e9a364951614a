"""Teacher-forced keyframe errors of a prior on stored demonstrations: what validation picks checkpoints by and
what ``benchmarks/investigations/prior_keyframe_errors.py`` reports per task."""

from __future__ import annotations

from typing import Protocol

import numpy as np
import torch

from bimanualshift.priors import UnimanualPrior


class KeyframeBatches(Protocol):
    def __len__(self) -> int: ...

    def batch(self, index: torch.Tensor) -> tuple[tuple[torch.Tensor, ...], dict[str, torch.Tensor]]: ...


def keyframe_errors(model: UnimanualPrior, batches: KeyframeBatches, batch_size: int = 16
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Translation error (m) and rotation error (degrees) of the first predicted action per keyframe, and a
    coarse-to-fine prior's first-stage translation error (None for single-stage priors)."""
    trans, rot, coarse = [], [], []
    with torch.no_grad():
        for start in range(0, len(batches), batch_size):
            inputs, actions = batches.batch(torch.arange(start, min(start + batch_size, len(batches))))
            pred = model.predict(*inputs)
            target = actions["position"][:, 0]
            trans += (pred.position - target).norm(dim=-1).tolist()
            if pred.coarse_position is not None:
                coarse += (pred.coarse_position - target).norm(dim=-1).tolist()
            dot = (pred.quat * actions["quat"][:, 0]).sum(-1).abs().clamp(max=1.0)
            rot += torch.rad2deg(2 * torch.arccos(dot)).tolist()
    return np.asarray(trans), np.asarray(rot), (np.asarray(coarse) if coarse else None)


def validation_summary(model: UnimanualPrior, batches: KeyframeBatches, tolerance_m: float = 0.03
                       ) -> dict[str, float]:
    """The checkpoint-picking value (minus the fraction of keyframes within ``tolerance_m``; lower is better) and
    the median translation (cm; a coarse-to-fine prior's first stage too) and rotation (degrees) errors."""
    trans, rot, coarse = keyframe_errors(model, batches)
    out = {"value": -float(np.mean(trans < tolerance_m)), "median_cm": round(100 * float(np.median(trans)), 3),
           "within_1cm": round(float(np.mean(trans < 0.01)), 4), "median_deg": round(float(np.median(rot)), 2)}
    if coarse is not None:
        out["median_cm_stage1"] = round(100 * float(np.median(coarse)), 3)
    return out
