"""Optimiser set-up: LAMB (as in PerAct and the paper) from the maintained torch-optimizer package."""

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
