"""Choose how much of the trained residual to apply, on validation demos.

A residual trained on a few demos corrects a prior that is far off (an unseen task) but also moves keyframes the
prior already places well, where a centimetre decides success. After training, the translation and the rotation
residual are each scaled by the factor in ``SCALE_GRID`` that minimises a clipped validation error: an error
beyond the clip counts as a miss of fixed cost, so a few keyframes the prior misses by far cannot buy a scale
that spoils the many it places well.
"""

from __future__ import annotations

from typing import Any

import torch

from bimanualshift.residual.manager import ResidualPolicy, keyframe_slots

SCALE_GRID = (1.0, 0.75, 0.5, 0.25, 0.0)  # on a tie the larger factor wins (the order min() sees them in)
TRANSLATION_CLIP_M = 0.05
ROTATION_CLIP_RAD = 0.35  # about 20 degrees


def clipped_error(target: torch.Tensor, prediction: torch.Tensor, scale: float, clip: float) -> float:
    """Mean over samples of min(|target - scale * prediction|, clip)."""
    return float((target - scale * prediction).norm(dim=-1).clamp_max(clip).mean())


@torch.no_grad()
def choose_output_scale(residual: ResidualPolicy, inputs: torch.Tensor, translation: torch.Tensor,
                        rotation: torch.Tensor) -> dict[str, Any]:
    """Set ``residual.output_scale`` from validation data (targets: expert minus prior, arm frame) and return the
    chosen factors with each one's clipped error and the error of the prior alone (factor 0). With
    ``gate_per_keyframe`` each keyframe slot gets its own factors, chosen on that slot's samples; a slot no
    validation sample reaches keeps the factors chosen on all of them."""
    if not residual.config.output_gate:
        raise ValueError("this residual was built with output_gate=False; train it with --output-gate true")
    if len(inputs) == 0:
        raise ValueError("no validation samples to choose the residual's output scale on; collect validation "
                         "demos (`bimanualshift collect --split validation`)")
    residual.output_scale.fill_(1.0)
    out = residual(inputs)
    parts = (("translation", translation, TRANSLATION_CLIP_M), ("rotation", rotation, ROTATION_CLIP_RAD))
    chosen: dict[str, Any] = {}
    overall = []
    for name, target, clip in parts:
        best, costs = best_scale(target, out[name], clip)
        overall.append(best)
        chosen[f"{name}_scale"] = best
        chosen[f"{name}_clipped_error"] = round(costs[best], 5)
        chosen[f"{name}_clipped_error_prior"] = round(costs[0.0], 5)
    residual.output_scale.copy_(torch.tensor(overall).expand_as(residual.output_scale))  # every slot, or one row
    if not residual.config.gate_per_keyframe:
        return chosen
    slots = keyframe_slots(residual.config, inputs)
    seen = sorted({int(s) for s in slots})
    for slot in seen:
        rows = slots == slot
        for i, (name, target, clip) in enumerate(parts):
            residual.output_scale[slot, i] = best_scale(target[rows], out[name][rows], clip)[0]
    per_keyframe: dict[str, Any] = {"keyframes": seen}
    for i, (name, target, clip) in enumerate(parts):
        per_keyframe[f"{name}_scale"] = [float(residual.output_scale[s, i]) for s in seen]
        scaled = out[name] * residual.output_scale[slots, i:i + 1]
        per_keyframe[f"{name}_clipped_error"] = round(clipped_error(target, scaled, 1.0, clip), 5)
    chosen["per_keyframe"] = per_keyframe
    return chosen


def clipped_pose_error(out: dict[str, torch.Tensor], translation: torch.Tensor, rotation: torch.Tensor) -> float:
    """The gate's measure of a residual's whole output (factor 1): the mean translation error clipped at
    ``TRANSLATION_CLIP_M`` over that clip plus the mean rotation error clipped at ``ROTATION_CLIP_RAD`` over that
    clip, each in [0, 1] (what ``select_by="clipped_error"`` picks a checkpoint by)."""
    return (clipped_error(translation, out["translation"], 1.0, TRANSLATION_CLIP_M) / TRANSLATION_CLIP_M
            + clipped_error(rotation, out["rotation"], 1.0, ROTATION_CLIP_RAD) / ROTATION_CLIP_RAD)


def best_scale(target: torch.Tensor, prediction: torch.Tensor, clip: float) -> tuple[float, dict[float, float]]:
    """The factor of ``SCALE_GRID`` with the least clipped error on these samples, and every factor's error."""
    costs = {s: clipped_error(target, prediction, s, clip) for s in SCALE_GRID}
    return min(SCALE_GRID, key=lambda s: costs[s]), costs


def reset_output_scale(residual: ResidualPolicy) -> None:
    """Apply the whole residual again (before further training: a zero factor would block its gradient)."""
    if residual.config.output_gate:
        residual.output_scale.fill_(1.0)
