"""Segmenter backends by name: ``simulator``, ``grounded_sam`` and ``degraded-mild`` / ``degraded-strong``
(the simulator segmenter with detector-like errors)."""

from __future__ import annotations

from bimanualshift.perception.segmenters.base import Segmenter

SEGMENTERS = ("simulator", "grounded_sam", "degraded-mild", "degraded-strong")


def make_segmenter(name: str, seed: int = 0, **grounded_sam: str | float) -> Segmenter:
    from dataclasses import replace

    from bimanualshift.perception.segmenters.degraded import LEVELS, DegradedSegmenter
    from bimanualshift.perception.segmenters.simulator import SimulatorSegmenter

    if name == "simulator":
        return SimulatorSegmenter()
    if name == "grounded_sam":
        from bimanualshift.perception.segmenters.grounded_sam import GroundedSamConfig, GroundedSamSegmenter

        return GroundedSamSegmenter(GroundedSamConfig(**grounded_sam))  # type: ignore[arg-type]
    if name.startswith("degraded-") and name.removeprefix("degraded-") in LEVELS:
        return DegradedSegmenter(SimulatorSegmenter(), replace(LEVELS[name.removeprefix("degraded-")], seed=seed))
    raise ValueError(f"unknown segmenter {name!r}; choose one of {', '.join(SEGMENTERS)}")
