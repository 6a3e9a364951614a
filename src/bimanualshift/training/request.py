"""What the benchmark hands every method's trainer: one task's demos and where to put the run."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class TrainRequest:
    task: str
    data: str  # train demos (one sub-folder per task)
    validation_data: str  # validation demos (checkpoint choice)
    demos: int
    prior: str  # the frozen single-arm prior (a folder or a shipped name)
    out: str  # the method's run directory for this task
    steps: int  # training steps (the benchmark: BenchConfig.steps, else the method's own)
    seed: int = 0
    overrides: dict[str, Any] = field(default_factory=dict)  # the method's own training options
    workers: int = 1  # processes a trainer may roll out in (a resource: not part of what the run measures)
    log: str = "none"  # training curves (tensorboard, wandb): how a run is watched, not what it measures
