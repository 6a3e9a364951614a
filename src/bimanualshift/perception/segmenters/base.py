"""The segmenter interface: image + text prompts -> instance masks with labels and scores."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


@dataclass
class Detection:
    mask: np.ndarray  # (H, W) bool
    label: str  # the prompt it answers, e.g. "robotic arm" or "button"
    score: float


@dataclass
class CameraView:
    """One camera image; simulator-backed segmenters also read the renderer's label maps."""

    rgb: np.ndarray  # (H, W, 3) uint8
    instance: np.ndarray | None = None  # (H, W) int
    class_ids: np.ndarray | None = None  # (H, W) int
    class_names: list[str] | None = None
    instance_colours: list[list[str]] | None = None  # instance id -> its painted colour names (simulator only)


class Segmenter(Protocol):
    def segment(self, view: CameraView, prompts: list[str]) -> list[Detection]: ...
