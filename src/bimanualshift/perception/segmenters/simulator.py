"""A segmenter that reads the simulator's labels but answers like an open-vocabulary detector would.

It returns one unlabelled "robotic arm" candidate per visible robot (never "left" or "right": telling the
arms apart is the projection's job) and one mask per visible object whose class matches a goal prompt. A
prompt with a colour attribute ("navy button") matches only the objects of that class painted that colour, as
a grounding detector answers a referring expression; when the view carries no colours it matches the class.
"""

from __future__ import annotations

import numpy as np

from bimanualshift.core.goal_nouns import split_prompt
from bimanualshift.perception.segmenters.base import CameraView, Detection


class SimulatorSegmenter:
    def __init__(self, min_pixels: int = 4) -> None:
        self.min_pixels = min_pixels

    def segment(self, view: CameraView, prompts: list[str]) -> list[Detection]:
        if view.instance is None or view.class_ids is None or view.class_names is None:
            raise ValueError("SimulatorSegmenter needs the renderer's instance and class maps in the CameraView")
        # One pass over the image: the pixel count of every (class, instance) pair present.
        n_inst = int(view.instance.max()) + 1
        pair = view.class_ids.astype(np.int32) * n_inst + view.instance
        counts = np.bincount(pair.ravel(), minlength=len(view.class_names) * n_inst).reshape(-1, n_inst)
        detections = []
        for prompt in prompts:
            colour, noun = split_prompt(prompt)
            if prompt in view.class_names:
                colour, noun = None, prompt
            if noun not in view.class_names:
                continue
            for inst in np.flatnonzero(counts[view.class_names.index(noun)] >= self.min_pixels):
                if colour is not None and view.instance_colours and colour not in view.instance_colours[inst]:
                    continue
                detections.append(Detection(view.instance == inst, prompt, 1.0))
        return detections
