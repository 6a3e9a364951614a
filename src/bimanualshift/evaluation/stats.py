"""Success-rate statistics: Wilson score intervals at 95 %, the paired sign test of two methods on the same seeds,
and the success row every result file holds."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, TypeVar

Scene = TypeVar("Scene", int, tuple[Any, ...])  # a seed, or (task, perturbation, seed)


def episode_key(record: Mapping[str, Any]) -> tuple[str, str, str, int]:
    """An episode record's identity in a bench folder's logs: (task, method, perturbation, seed)."""
    return record["task"], record["method"], record.get("perturbation", "none"), int(record["seed"])


def wilson_interval(successes: int, trials: int, z: float = 1.959964) -> tuple[float, float]:
    if trials <= 0:
        raise ValueError("a success rate needs at least one trial")
    if not 0 <= successes <= trials:
        raise ValueError(f"successes ({successes}) must lie in [0, trials={trials}]")
    p = successes / trials
    denom = 1 + z * z / trials
    centre = (p + z * z / (2 * trials)) / denom
    half = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


@dataclass(frozen=True)
class PairedComparison:
    """Two methods rolled out on the same episodes: where they disagree, and how likely that split is if neither
    is better (the exact two-sided sign test, McNemar's test for small counts)."""

    pairs: int
    a_wins: int  # episodes a solved and b did not
    b_wins: int
    p_value: float


def paired_sign_test(a: Iterable[bool], b: Iterable[bool]) -> PairedComparison:
    """Compare success flags of two methods episode by episode (``a[i]`` and ``b[i]`` are the same seed)."""
    a, b = [bool(x) for x in a], [bool(x) for x in b]
    if len(a) != len(b):
        raise ValueError(f"paired episodes need the same count, got {len(a)} and {len(b)}")
    a_wins = sum(x and not y for x, y in zip(a, b))
    b_wins = sum(y and not x for x, y in zip(a, b))
    n, k = a_wins + b_wins, min(a_wins, b_wins)
    tail = sum(math.comb(n, i) for i in range(k + 1)) / 2 ** n if n else 0.5
    return PairedComparison(len(a), a_wins, b_wins, min(1.0, 2 * tail))


def pair_by_scene(a: Mapping[Scene, bool], b: Mapping[Scene, bool]) -> tuple[list[Scene], list[bool], list[bool]]:
    """The scenes (a seed, or a task, perturbation and seed) both methods ran, sorted, and each method's outcomes on
    them in that order: what ``paired_sign_test`` compares. A scene only one method ran carries no paired evidence."""
    scenes = sorted(scene for scene in a if scene in b)
    return scenes, [bool(a[s]) for s in scenes], [bool(b[s]) for s in scenes]


@dataclass(frozen=True)
class SuccessRate:
    """k successes in n episodes: what every success row of every result file is built from."""

    successes: int
    episodes: int

    @staticmethod
    def of(outcomes: Iterable[bool]) -> SuccessRate:
        outcomes = [bool(o) for o in outcomes]
        return SuccessRate(sum(outcomes), len(outcomes))

    @property
    def rate(self) -> float:
        return self.successes / self.episodes

    def fields(self) -> dict[str, Any]:
        """``success``, ``episodes`` and the Wilson ``ci95``, rounded as result files hold them."""
        lo, hi = wilson_interval(self.successes, self.episodes)
        return {"success": round(self.rate, 4), "episodes": self.episodes, "ci95": [round(lo, 4), round(hi, 4)]}


@dataclass
class SuccessRow:
    """One measured cell of a result file. ``to_dict`` gives the keys of docs/results-format.md in order: task,
    method, the cell's context (demos, perturbation, ...), success, episodes, ci95, then its details (stages,
    mean keyframes, failed seeds, ...)."""

    task: str
    method: str
    rate: SuccessRate
    context: dict[str, Any] = field(default_factory=dict)
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"task": self.task, "method": self.method, **self.context, **self.rate.fields(), **self.details}
