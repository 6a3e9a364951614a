"""Disjoint seed ranges: training demos, validation (checkpoint choice) and test (reported numbers)."""

from __future__ import annotations

SPLIT_OFFSETS = {"train": 0, "validation": 100_000, "test": 200_000}
# Where in the validation split candidate priors are compared (prior-report --split validation): past every validation
# demo (from 0) and the benchmark's validation rollouts (from 10,000) and rollout choices (from 20,000)
PRIOR_CHOICE_START = 30_000


def split_seeds(split: str, count: int, start: int = 0) -> list[int]:
    if split not in SPLIT_OFFSETS:
        raise ValueError(f"unknown split {split!r}; choose one of {sorted(SPLIT_OFFSETS)}")
    if count < 0 or start < 0 or start + count > 100_000:
        raise ValueError(f"seed range [{start}, {start + count}) must lie in [0, 100000)")
    base = SPLIT_OFFSETS[split] + start
    return list(range(base, base + count))
