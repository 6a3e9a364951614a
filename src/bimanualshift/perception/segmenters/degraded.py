"""A wrapper that makes any segmenter's output worse in controlled ways, to study robustness to detector
errors: masks eroded or dilated, detections dropped, the two arm candidates merged into one (as a detector
does when the arms cross) and false positives added. Every rate is configurable and the noise is seeded.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from bimanualshift.perception.segmenters.base import CameraView, Detection, Segmenter
from bimanualshift.sim.segmentation import ARM_CLASS


@dataclass(frozen=True)
class Degradation:
    boundary_px: int = 0  # each mask is eroded or dilated by a random radius in [-boundary_px, boundary_px]
    drop: float = 0.0  # probability that a detection is lost
    merge_arms: float = 0.0  # probability that two "robotic arm" candidates come back as one mask
    false_positives: float = 0.0  # expected spurious detections per image (Poisson), random blobs
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("drop", "merge_arms"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"Degradation.{name} is a probability in [0, 1], got {value}")
        if self.boundary_px < 0 or self.false_positives < 0:
            raise ValueError("Degradation.boundary_px and .false_positives must be >= 0")


# The two noise levels the projection-quality study reports.
LEVELS = {
    "mild": Degradation(boundary_px=1, drop=0.05, merge_arms=0.05, false_positives=0.2),
    "strong": Degradation(boundary_px=3, drop=0.15, merge_arms=0.2, false_positives=0.6),
}


class DegradedSegmenter:
    def __init__(self, inner: Segmenter, degradation: Degradation) -> None:
        self.inner = inner
        self.degradation = degradation
        self.rng = np.random.default_rng(degradation.seed)

    def segment(self, view: CameraView, prompts: list[str]) -> list[Detection]:
        d, rng = self.degradation, self.rng
        detections = [det for det in self.inner.segment(view, prompts) if rng.random() >= d.drop]
        arms = [det for det in detections if det.label == ARM_CLASS]
        if len(arms) >= 2 and rng.random() < d.merge_arms:
            merged = Detection(arms[0].mask | arms[1].mask, ARM_CLASS, min(arms[0].score, arms[1].score))
            detections = [det for det in detections if det is not arms[0] and det is not arms[1]] + [merged]
        out = []
        for det in detections:
            mask = det.mask
            radius = int(rng.integers(-d.boundary_px, d.boundary_px + 1)) if d.boundary_px else 0
            if radius > 0:
                mask = ndimage.binary_dilation(mask, iterations=radius)
            elif radius < 0:
                mask = ndimage.binary_erosion(mask, iterations=-radius)
            if mask.any():
                out.append(Detection(mask, det.label, det.score))
        h, w = view.rgb.shape[:2]
        for _ in range(rng.poisson(d.false_positives)):
            out.append(Detection(_random_blob(rng, h, w), str(rng.choice(prompts)), float(rng.uniform(0.3, 0.6))))
        return out


def _random_blob(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    """An ellipse covering roughly 0.5-4 % of the image at a random place."""
    cy, cx = rng.uniform(0, h), rng.uniform(0, w)
    ry, rx = rng.uniform(0.04, 0.12) * h, rng.uniform(0.04, 0.12) * w
    yy, xx = np.mgrid[:h, :w]
    return ((yy - cy) / ry) ** 2 + ((xx - cx) / rx) ** 2 <= 1.0
