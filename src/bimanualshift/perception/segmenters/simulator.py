"""A segmenter that reads the simulator's labels but answers like an open-vocabulary detector would.

It returns one unlabelled "robotic arm" candidate per visible robot (never "left" or "right": telling the
arms apart is the projection's job) and one mask per visible object whose class matches a goal prompt.
"""

from __future__ import annotations

import numpy as np

from bimanualshift.perception.segmenters.base import CameraView, Detection
from bimanualshift.sim.segmentation import ARM_CLASS


class SimulatorSegmenter:
    def __init__(self, min_pixels: int = 4) -> None:
        self.min_pixels = min_pixels

    def segment(self, view: CameraView, prompts: list[str]) -> list[Detection]:
        if view.instance is None or view.class_ids is None or view.class_names is None:
            raise ValueError("SimulatorSegmenter needs the renderer's instance and class maps in the CameraView")
        detections = []
        for prompt in prompts:
            if prompt not in view.class_names:
                continue
            cls = view.class_names.index(prompt)
            in_class = view.class_ids == cls
            for inst in np.unique(view.instance[in_class]):
                mask = in_class & (view.instance == inst)
                if mask.sum() >= self.min_pixels:
                    detections.append(Detection(mask, ARM_CLASS if prompt == ARM_CLASS else prompt, 1.0))
        return detections
