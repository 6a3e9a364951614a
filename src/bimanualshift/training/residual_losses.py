"""The residual's losses (L_BC of Eq. 12 with its coordination terms), the validation losses its checkpoints are
chosen by, and the per-keyframe reports of how far the prior alone and prior + residual land from the targets."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch
import torch.nn.functional as F
from scipy.spatial.transform import Rotation

from bimanualshift.residual.manager import ResidualPolicy, action_lattice, arm_and_slot, keyframe_slots
from bimanualshift.residual.output_gate import clipped_pose_error
from bimanualshift.training.residual_data import ResidualData


@dataclass(frozen=True)
class LossWeights:
    """Weights of L_BC's terms (Eq. 12 and its coordination extension, docs/residual.md)."""

    beta: float = 1.0  # rotation (rad^2) against translation (m^2)
    # The gripper's and the hold's binary cross-entropies: their scale (~0.1-0.7) dwarfs squared metres (a 2 cm
    # error is 4e-4), so they are turned down to keep the shared Manager's gradient mostly on the pose.
    gripper: float = 0.01
    hold: float = 0.01


SELECT_BY = ("pose_loss", "clipped_error")


@torch.no_grad()
def validation_losses(residual: ResidualPolicy, data: ResidualData, weights: LossWeights,
                      select_by: str = "pose_loss") -> dict[str, float]:
    """What picks a residual checkpoint (``value``): the pose part of L_BC (translation + beta * rotation, Eq. 12
    as written) or, with ``select_by="clipped_error"``, the output gate's clipped errors over their clips
    (``TrainConfig.select_by``); never the coordination outputs' cross-entropies, an order of magnitude larger,
    which could choose an undertrained pose residual: they are logged beside it, with each coordination output's
    validation accuracy. An action-space residual has no continuous move to clip: it is picked by its pose loss."""
    if select_by not in SELECT_BY:
        raise ValueError(f"select_by must be one of {SELECT_BY}, got {select_by!r}")
    out = residual(data.inputs)
    losses = bc_loss(out, data, weights)
    report = {"value": float(losses["translation"] + weights.beta * losses["rotation"])}
    if select_by == "clipped_error" and "translation_logits" not in out:
        report["pose_loss"] = report["value"]
        report["value"] = clipped_pose_error(out, data.translation, data.rotation)
    for name, logit, target in (("gripper", "gripper_logit", data.gripper), ("hold", "hold_logit", data.hold)):
        if logit in out and target is not None:
            report[f"{name}_bce"] = round(float(losses[name]), 5)
            report[f"{name}_accuracy"] = round(float(((out[logit] > 0).float() == target).float().mean()), 4)
    return report


def bc_loss(out: dict[str, torch.Tensor], data: ResidualData, weights: LossWeights) -> dict[str, torch.Tensor]:
    """Eq. 12 on the final action: a = prior + G(v), so the error of a equals the residual's error; with the
    coordination outputs, the binary cross-entropy of the final gripper logit and of the hold logit too. An
    action-space residual's pose terms are cross-entropies of the summed logits (the prior's log-probabilities +
    the residual's) against the expert's lattice cell and rotation bins."""
    if "translation_logits" in out:
        if data.target_cell is None:
            raise ValueError("this residual works in the prior's action space but the data has no lattice targets")
        trans = F.cross_entropy(data.prior_translation + out["translation_logits"], data.target_cell)
        r = data.prior_rotation.shape[-1]
        rot = F.cross_entropy((data.prior_rotation + out["rotation_logits"]).reshape(-1, r), data.target_bins.flatten())
    else:
        trans = ((out["translation"] - data.translation) ** 2).sum(-1).mean()
        rot = ((out["rotation"] - data.rotation) ** 2).sum(-1).mean()
    losses = {"translation": trans, "rotation": rot}
    total = trans + weights.beta * rot
    for name, logit, target, weight in (("gripper", "gripper_logit", data.gripper, weights.gripper),
                                        ("hold", "hold_logit", data.hold, weights.hold)):
        if logit in out:
            if target is None:
                raise ValueError(f"this residual predicts a {name} logit but the data has no {name} targets")
            losses[name] = F.binary_cross_entropy_with_logits(out[logit], target)
            total = total + weight * losses[name]
    return {**losses, "total": total}


def translation_report(residual: ResidualPolicy, data: ResidualData) -> dict[str, Any]:
    """How far the prior alone and prior + residual land from the expert's position (validation data)."""
    with torch.no_grad():
        out = residual(data.inputs)
        if "translation_logits" in out:  # the chosen lattice cell's offset is the residual's move
            cells = action_lattice(residual.config)
            chosen = (data.prior_translation + out["translation_logits"]).argmax(-1)
            corrected = data.translation - cells[chosen]
        else:
            corrected = data.translation - out["translation"]
    report: dict[str, Any] = {}
    errors = (("prior", data.translation.norm(dim=-1)), ("prior_plus_residual", corrected.norm(dim=-1)))
    for name, err in errors:
        report[f"{name}_median_m"] = round(float(err.median()), 4)
        report[f"{name}_within_2cm"] = round(float((err < 0.02).float().mean()), 4)
    if residual.config.phase_dim:  # where along the task the residual helps or hurts (median per keyframe slot)
        slots = keyframe_slots(residual.config, data.inputs)
        seen = sorted({int(s) for s in slots})
        report["per_keyframe"] = {"keyframes": seen, **{f"{name}_median_m": [
            round(float(err[slots == s].median()), 4) for s in seen] for name, err in errors}}
    return report


def rotation_report(residual: ResidualPolicy, data: ResidualData) -> dict[str, Any]:
    """How far the prior alone and prior + residual turn from the orientation the residual is trained towards (the
    expert's, or its grasp twin with ``rotation_target="nearest_twin"``; radians, validation data), per arm and
    keyframe slot when the inputs carry the phase: a large correction learnt only in part shows there (sweep's
    dustpan grasp). Empty for a residual in the prior's action space, whose rotation is bins."""
    with torch.no_grad():
        out = residual(data.inputs)
    if "rotation_logits" in out:
        return {}
    # exp(target) * R_prior = R_expert and exp(out) * R_prior = R_final, so R_final^-1 R_expert's angle is the error
    target = Rotation.from_rotvec(data.rotation.double().numpy())
    final = Rotation.from_rotvec(out["rotation"].double().numpy())
    errors = (("prior", torch.from_numpy(target.magnitude())),
              ("prior_plus_residual", torch.from_numpy((final.inv() * target).magnitude())))
    report: dict[str, Any] = {f"{name}_median_rad": round(float(err.median()), 4) for name, err in errors}
    if residual.config.phase_dim:
        arms, slots = arm_and_slot(residual.config, data.inputs)
        for arm in sorted({int(a) for a in arms}):
            seen = sorted({int(s) for s in slots[arms == arm]})
            report[f"arm_{arm}_per_keyframe"] = {"keyframes": seen, **{f"{name}_median_rad": [
                round(float(err[(arms == arm) & (slots == s)].median()), 4) for s in seen] for name, err in errors}}
    return report
