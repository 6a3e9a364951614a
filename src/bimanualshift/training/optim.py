"""Optimiser set-up: LAMB (as in PerAct and the paper) from the maintained torch-optimizer package, or AdamW
(as in Diffusion Policy)."""

from __future__ import annotations

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




def make_optimizer(name: str, params: Iterable[torch.nn.Parameter], lr: float) -> torch.optim.Optimizer:
    if name == "lamb":
        return make_lamb(params, lr=lr)
    if name == "adamw":
        params = [p for p in params if p.requires_grad]
        if not params:
            raise ValueError("nothing to optimise: every parameter is frozen")
        return torch.optim.AdamW(params, lr=lr, weight_decay=1e-6)
    raise ValueError(f"unknown optimizer {name!r}; choose from {OPTIMIZERS}")
