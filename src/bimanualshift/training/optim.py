"""Optimiser set-up: LAMB (as in PerAct and the paper) from the maintained torch-optimizer package, or AdamW
(as in Diffusion Policy)."""

from __future__ import annotations

import math
from collections.abc import Iterable

import torch
import torch_optimizer


def make_lamb(params: Iterable[torch.nn.Parameter], lr: float = 5e-4, weight_decay: float = 1e-6
              ) -> torch.optim.Optimizer:
    params = [p for p in params if p.requires_grad]
    if not params:
        raise ValueError("nothing to optimise: every parameter is frozen")
    return torch_optimizer.Lamb(params, lr=lr, weight_decay=weight_decay)


OPTIMIZERS = ("lamb", "adamw")
SCHEDULES = ("constant", "cosine")
MIN_LR_FACTOR = 0.05  # where the cosine decay ends


def lr_factor(schedule: str, step: int, steps: int, warmup_steps: int = 0) -> float:
    """The learning rate at ``step`` as a fraction of the configured one; a function of the step alone, so a
    resumed run continues the schedule exactly."""
    if schedule == "constant":
        return 1.0
    if schedule != "cosine":
        raise ValueError(f"unknown learning-rate schedule {schedule!r}; choose from {SCHEDULES}")
    if step < warmup_steps:
        return (step + 1) / warmup_steps
    progress = (step - warmup_steps) / max(1, steps - warmup_steps)
    return MIN_LR_FACTOR + (1 - MIN_LR_FACTOR) * 0.5 * (1 + math.cos(math.pi * min(progress, 1.0)))




def make_optimizer(name: str, params: Iterable[torch.nn.Parameter], lr: float) -> torch.optim.Optimizer:
    if name == "lamb":
        return make_lamb(params, lr=lr)
    if name == "adamw":
        params = [p for p in params if p.requires_grad]
        if not params:
            raise ValueError("nothing to optimise: every parameter is frozen")
        return torch.optim.AdamW(params, lr=lr, weight_decay=1e-6)
    raise ValueError(f"unknown optimizer {name!r}; choose from {OPTIMIZERS}")
