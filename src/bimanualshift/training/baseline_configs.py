"""The typed training options of the backbone baselines (no torch here: the method registry reads them)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class BackboneTrainConfig:
    """How a backbone network is trained (the request holds task, demos, steps and seed)."""

    size: str = "default"  # a named model size from bimanualshift.configs (default, debug, ...)
    lr: float = 1e-3
    batch_size: int = 4
    checkpoint_every: int = 250
    optimizer: str = "lamb"  # lamb (PerAct) or adamw (Diffusion Policy, ACT)


@dataclass(frozen=True)
class LeaderFollowerTrainConfig(BackboneTrainConfig):
    lr: float = 5e-4
    kind: str = "peract"  # the prior network the pair is fine-tuned from: peract, diffusion or rvt
    prior: str = ""  # the prior to fine-tune ("" = the benchmark's --prior)
    init_from: str = ""  # continual learning: an earlier pair's run folder; each network starts from its own weights
