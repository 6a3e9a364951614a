"""Grounded-SAM through ``transformers``: Grounding DINO turns the text prompts into boxes, SAM turns the
boxes into masks. This is the segmenter for a real robot.

Weights load with ``from_pretrained`` from a local directory (a ``save_pretrained`` folder with
``config.json`` + ``model.safetensors`` and the processor files) or a hub id when the network allows.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from bimanualshift.perception.segmenters.base import CameraView, Detection


@dataclass(frozen=True)
class GroundedSamConfig:
    detector: str = "IDEA-Research/grounding-dino-tiny"  # hub id or local directory
    sam: str = "facebook/sam-vit-base"  # hub id or local directory
    box_threshold: float = 0.35
    text_threshold: float = 0.25
    max_per_prompt: int = 4  # the best-scoring boxes kept per prompt
    device: str = "cpu"


def _load(kind: str, source: str, loader: Callable[[str], Any]) -> Any:
    local = Path(source).expanduser()
    if local.exists():
        if not (local / "config.json").is_file():
            raise FileNotFoundError(f"{kind}: {local} has no config.json; give a folder written by save_pretrained "
                                    "or a hub id")
        source = str(local)
    try:
        return loader(source)
    except OSError as exc:
        raise OSError(f"{kind}: could not load {source!r} ({exc}). Without network access, download the weights "
                      "elsewhere, save them with save_pretrained and pass the local folder.") from exc


class GroundedSamSegmenter:
    def __init__(self, config: GroundedSamConfig | None = None) -> None:
        from transformers import AutoModelForZeroShotObjectDetection, AutoProcessor, SamModel, SamProcessor

        self.config = config or GroundedSamConfig()
        c = self.config
        self.detector_processor = _load("Grounding DINO processor", c.detector, AutoProcessor.from_pretrained)
        self.detector = _load("Grounding DINO", c.detector, AutoModelForZeroShotObjectDetection.from_pretrained)
        self.sam_processor = _load("SAM processor", c.sam, SamProcessor.from_pretrained)
        self.sam = _load("SAM", c.sam, SamModel.from_pretrained)
        self.detector.to(c.device).eval()
        self.sam.to(c.device).eval()

    @torch.no_grad()
    def segment(self, view: CameraView, prompts: list[str]) -> list[Detection]:
        if not prompts:
            return []
        c = self.config
        image = np.asarray(view.rgb)
        h, w = image.shape[:2]
        text = ". ".join(p.lower() for p in prompts) + "."
        inputs = self.detector_processor(images=image, text=text, return_tensors="pt").to(c.device)
        outputs = self.detector(**inputs)
        result = self.detector_processor.post_process_grounded_object_detection(
            outputs, inputs["input_ids"], threshold=c.box_threshold, text_threshold=c.text_threshold,
            target_sizes=[(h, w)])[0]
        boxes, scores, labels = [], [], []
        kept: dict[str, int] = {}
        for box, score, phrase in sorted(zip(result["boxes"].tolist(), result["scores"].tolist(),
                                             result["text_labels"]), key=lambda r: -r[1]):
            prompt = match_prompt(phrase, prompts)
            if prompt is None or kept.get(prompt, 0) >= c.max_per_prompt:
                continue
            kept[prompt] = kept.get(prompt, 0) + 1
            boxes.append([min(max(v, 0.0), lim) for v, lim in zip(box, (w, h, w, h))])
            scores.append(float(score))
            labels.append(prompt)
        if not boxes:
            return []
        sam_inputs = self.sam_processor(images=image, input_boxes=[boxes], return_tensors="pt").to(c.device)
        sam_out = self.sam(**sam_inputs, multimask_output=False)
        masks = self.sam_processor.image_processor.post_process_masks(
            sam_out.pred_masks, sam_inputs["original_sizes"], sam_inputs["reshaped_input_sizes"])[0]
        return [Detection(masks[i, 0].numpy().astype(bool), labels[i], scores[i]) for i in range(len(labels))]


def match_prompt(phrase: str, prompts: list[str]) -> str | None:
    """The prompt a detected phrase answers: the one sharing the most words with it (None if none does)."""
    words = set(phrase.lower().replace(".", " ").split())
    best, overlap = None, 0
    for prompt in prompts:
        shared = len(words & set(prompt.lower().split()))
        if shared > overlap:
            best, overlap = prompt, shared
    return best
