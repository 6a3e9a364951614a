"""`bimanualshift demo`: the whole method end to end on push_two_buttons, on a laptop CPU.

1. collect bimanual expert demos (train + validation seeds) in simulation;
2. load the shipped single-arm prior (or pretrain one on freshly collected single-arm demos);
3. train the residual branch (Manager, Z, G) with the prior and projection frozen;
4. evaluate BimanualShift and the frozen-prior-per-arm baseline on held-out test seeds;
5. print a success table with 95 % CIs, write results/demo/summary.json and one image strip per method.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from bimanualshift.configs import DEFAULT_PRIOR, RESIDUAL_STEPS

SHIPPED_PRIOR = Path(__file__).resolve().parents[3] / "checkpoints" / DEFAULT_PRIOR


@dataclass
class DemoConfig:
    task: str = "push_two_buttons"
    demos: int = 20
    validation_demos: int = 5
    test_episodes: int = 20
    max_keyframes: int = 6  # the expert needs 3; failing rollouts stop at twice that
    residual_steps: int = RESIDUAL_STEPS
    prior: str = str(SHIPPED_PRIOR)
    workdir: str = "runs/demo"
    results: str = "results/demo"
    workers: int = 2
    seed: int = 0
