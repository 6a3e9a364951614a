"""Training the residual branch on bimanual demos while the prior and the projection stay frozen
(`bimanualshift train`, Eq. 12-13 without the correction term, which needs refinement rollouts): the run's
settings and resumption, the prior's instruction, the samples (``residual_data``), the loop over the losses
(``residual_losses``), the output gate and the saved checkpoint.
"""

from __future__ import annotations

import json
import time
from dataclasses import MISSING, asdict, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
import torch

from bimanualshift.data.episode import list_episodes
from bimanualshift.encoders.text import default_text_encoder, make_text_encoder
from bimanualshift.memory.bank import MemoryBank
from bimanualshift.methods.bimanualshift import MEMORY_FILE, save_residual
from bimanualshift.methods.instruction_chooser import InstructionChooser
from bimanualshift.methods.prior_step import FrozenPriorStep, goal_switches
from bimanualshift.methods.role_assigner import RoleAssigner
from bimanualshift.perception.arm_samples import ArmSamples, build_arm_samples
from bimanualshift.priors.base import UnimanualPrior
from bimanualshift.residual.manager import NUM_ROLES, ResidualConfig, ResidualPolicy
from bimanualshift.residual.output_gate import choose_output_scale, reset_output_scale
from bimanualshift.residual.skills import SkillBasis
from bimanualshift.training.augment import Se3Augmentation
from bimanualshift.training.checkpoint import latest_checkpoint
from bimanualshift.training.closed_loop_choice import candidate_folders, choose_by_rollouts, keep_candidate
from bimanualshift.training.configs import TrainConfig
from bimanualshift.training.loop import run_training
from bimanualshift.training.metric_log import open_logger
from bimanualshift.training.optim import lr_factor, make_optimizer
from bimanualshift.training.prior_instruction import (
    AUTO,
    CHOICE_DEMOS,
    MARGIN,
    PER_ARM,
    PER_ARM_CHOICE_DEMOS,
    choose_arm_instructions,
    choose_prior_instruction,
    suite_instructions,
)
from bimanualshift.training.residual_data import hold_labels, residual_data
from bimanualshift.training.residual_losses import (
    SELECT_BY,
    LossWeights,
    bc_loss,
    rotation_report,
    translation_report,
    validation_losses,
)
from bimanualshift.training.roles import assigned_roles, demo_roles, first_keyframe_rows, fit_role_assigner
from bimanualshift.utils.config_files import load_safetensors, read_json_file
from bimanualshift.utils.io import atomic_write_json


def segmenter_options(grounding_dino: str, sam: str) -> dict[str, str]:
    """GroundedSamConfig overrides for the weights' locations; empty strings keep the defaults."""
    return {k: v for k, v in (("detector", grounding_dino), ("sam", sam)) if v}


def earlier_checkpoint(init_from: str) -> Path:
    """The checkpoint folder of an earlier run given as the run folder or the checkpoint itself."""
    for candidate in (Path(init_from) / "best", Path(init_from)):
        if (candidate / "config.json").is_file() and (candidate / "model.safetensors").is_file():
            return candidate
    raise FileNotFoundError(f"init_from={init_from!r}: no BimanualShift checkpoint there (expected config.json and "
                            "model.safetensors in it or in its best/ folder); give an earlier `bimanualshift train` "
                            "run folder")


def load_earlier(init_from: str, rcfg: ResidualConfig, retrieval: bool
                 ) -> tuple[dict[str, torch.Tensor], MemoryBank | None]:
    """An earlier run's residual weights (checked against this run's shapes) and, with retrieval, its bank."""
    checkpoint = earlier_checkpoint(init_from)
    earlier = read_json_file(checkpoint / "config.json")
    # "slot_twin"'s mean grasps come from each task's own demos, so they may differ (and JSON holds them as a list)
    fitted = {"twin_references": None, "heading_anchors": None}  # fitted on each run's own demos
    ours = {**asdict(rcfg), **fitted}
    # a switch added after the earlier run was saved held its default there (heading_anchor, say)
    added = {f.name: f.default for f in fields(rcfg) if f.default is not MISSING}
    if (not isinstance(earlier.get("residual"), dict)
            or {**added, **earlier["residual"], **fitted} != ours):
        raise ValueError(f"init_from={init_from!r} has residual config {earlier.get('residual')}, this run needs "
                         f"{asdict(rcfg)}; continue from a run with the same prior, text encoder and switches")
    memory = MemoryBank.load(checkpoint / MEMORY_FILE) if retrieval and (checkpoint / MEMORY_FILE).is_file() else None
    return load_safetensors(checkpoint / "model.safetensors"), memory


# What a resumed run may change: more steps extend it; the demos' folders may move.
RESUMABLE_CHANGES = ("optim.steps", "optim.log", "dataset.data", "dataset.validation_data", "out", "select_workers")


def changed_settings(cfg: TrainConfig) -> list[str]:
    """The settings (flattened ``group.field`` names) in which ``cfg`` differs from the run already in ``cfg.out``
    (none when the folder holds no run): resuming would continue weights trained under the other settings."""
    saved = Path(cfg.out) / "train_config.json"
    if not saved.is_file() or latest_checkpoint(cfg.out) is None:
        return []

    def flat(d: dict, prefix: str = "") -> dict:
        return {k2: v2 for k, v in d.items()
                for k2, v2 in (flat(v, f"{prefix}{k}.").items() if isinstance(v, dict) else [(f"{prefix}{k}", v)])}

    before, now = flat(read_json_file(saved)), flat(asdict(cfg))
    return sorted(k for k in now if k in before and before[k] != now[k] and k not in RESUMABLE_CHANGES)


PRIOR_INSTRUCTION_FILE = "prior_instruction.json"  # under the run folder: what `auto` chose, and from what


def resolve_prior_instruction(cfg: TrainConfig, prior_step: FrozenPriorStep, paths: list[Path], out: Path
                              ) -> tuple[dict[str, Any], ArmSamples | None]:
    """Set ``prior_step.prior_instruction`` (and its ``instruction_chooser``) from ``--prior-instruction``; ``auto``
    and ``per_arm`` choose on the first training demos once per run (a resumed run reads its earlier choice) and
    record the choice with its table. Returns the choice and, when it had to be made, every training demo's samples
    (built once, for the choice and then the residual), else None."""
    wanted = cfg.model.prior_instruction
    if wanted not in (AUTO, PER_ARM):
        prior_step.prior_instruction = wanted
        return {"prior_instruction": wanted}, None
    record = out / PRIOR_INSTRUCTION_FILE
    samples = None
    if record.is_file():
        chosen = read_json_file(record, "prior instruction choice")
    else:
        count = min(len(paths), CHOICE_DEMOS if wanted == AUTO else PER_ARM_CHOICE_DEMOS)
        samples = build_arm_samples(paths, prior_step.builder, prior_step.prior.config.max_keyframes,
                                    desc="voxelise train")
        first = samples.first_episodes(count)
        if wanted == AUTO:
            instruction, table = choose_prior_instruction(prior_step, first, suite_instructions(cfg.prior))
            chosen = {"prior_instruction": instruction, "margin": MARGIN, "chosen_on_demos": count,
                      "candidates": table}
        else:
            chooser, table = choose_arm_instructions(prior_step, first, suite_instructions(cfg.prior))
            chosen = {"prior_instruction": "", "instruction_chooser": chooser.to_dict() if chooser else None,
                      "margin": MARGIN, "chosen_on_demos": count, **table}
        atomic_write_json(record, chosen)
    prior_step.prior_instruction = chosen["prior_instruction"]
    saved_chooser = chosen.get("instruction_chooser")
    prior_step.instruction_chooser = InstructionChooser.from_dict(saved_chooser) if saved_chooser else None
    return chosen, samples


def role_record(samples: ArmSamples, val_samples: ArmSamples | None) -> tuple[RoleAssigner | None, dict[str, Any]]:
    """The role assigner fitted on the training demos' roles (None where each arm keeps one role: the per-arm slots
    say the same), and its record: how often it gives the validation demos their own (per episode)."""
    assigner = fit_role_assigner(samples, hold_labels(samples))
    record: dict[str, Any] = {"by_arm_order": assigner.chooser is None, "train_accuracy": assigner.accuracy}
    if assigner.chooser is not None and val_samples is not None and len(val_samples):
        first = first_keyframe_rows(val_samples)
        truth = demo_roles(val_samples, hold_labels(val_samples))[first]
        decided = assigned_roles(assigner, val_samples)[first]
        record["validation_accuracy"] = round(float(np.mean(truth == decided)), 4)
        record["validation_demos"] = int(len(np.unique(val_samples.episode)))
    return (None if assigner.chooser is None else assigner), record


def train_residual(cfg: TrainConfig, prior: UnimanualPrior | None = None) -> Path:
    started = time.time()
    out = Path(cfg.out)
    if cfg.select_by not in SELECT_BY:
        raise ValueError(f"--select-by must be one of {SELECT_BY}, got {cfg.select_by!r}")
    if cfg.select_rollouts < 0 or cfg.select_candidates < 1:
        raise ValueError(f"--select-rollouts must be >= 0 and --select-candidates >= 1, got {cfg.select_rollouts} "
                         f"and {cfg.select_candidates}")
    changed = changed_settings(cfg)
    if changed:
        raise ValueError(f"{out} holds a residual run trained with other settings ({', '.join(changed)}); resuming "
                         "would continue it under these: give this run its own --out, or delete that folder")
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / "train_config.json", asdict(cfg))
    text_encoder = make_text_encoder(cfg.model.text_encoder)  # the prior keeps the encoder it was pretrained with
    prior = prior if prior is not None else UnimanualPrior.from_pretrained(cfg.prior)
    bins = int(round(360 / prior.rotation_bin_degrees)) if prior.rotation_bin_degrees else 0
    if cfg.model.action_space and not bins:
        raise ValueError(f"the prior {cfg.prior} has no rotation bins and no translation heat-map: an action-space "
                         "residual needs a PerAct-style or RVT-style prior (train with --action-space false)")
    rcfg = cfg.model.residual_config(prior.feature_dim, text_encoder.dim, prior.proposal_feature_dim, bins)
    prior_step = FrozenPriorStep(prior, default_text_encoder(), use_projection=cfg.model.use_projection,
                             **goal_switches(rcfg.goal_dim, rcfg.start_goal_dim),
                             segmenter=cfg.model.segmenter,
                             segmenter_options=segmenter_options(cfg.model.grounding_dino, cfg.model.sam),
                             proposal_features=cfg.model.proposal_features)
    paths = list_episodes(cfg.dataset.data, cfg.dataset.task)[: cfg.dataset.demos]
    if not paths:
        raise FileNotFoundError(f"no bimanual demos for {cfg.dataset.task} under {cfg.dataset.data}; run "
                                f"`bimanualshift collect --task {cfg.dataset.task} --out {cfg.dataset.data}` first")
    instruction_choice, samples = resolve_prior_instruction(cfg, prior_step, paths, out)
    if cfg.model.proposal_features and not prior.proposal_feature_dim:
        raise ValueError(f"the prior {cfg.prior} exposes no local features for the Manager to read at its proposal; "
                         "train with --proposal-features false")
    data, model, optim = cfg.dataset, cfg.model, cfg.optim
    augmentation = Se3Augmentation(data.augment_translation_m, data.augment_yaw_deg)
    val_paths = list_episodes(cfg.dataset.validation_data, cfg.dataset.task)
    assigner, roles, val_samples = None, None, None
    if rcfg.role_phase:  # the demos' roles label the assigner, which decides the validation demos' as a rollout
        samples = samples or build_arm_samples(paths, prior_step.builder, prior.config.max_keyframes,
                                               desc="voxelise train")
        val_samples = (build_arm_samples(val_paths, prior_step.builder, prior.config.max_keyframes,
                                         desc="voxelise val") if val_paths else None)
        assigner, roles = role_record(samples, val_samples)
        if assigner is None:  # each arm plays one role throughout: the per-arm slots say the same
            rcfg = replace(rcfg, role_phase=False, phase_dim=rcfg.phase_dim // NUM_ROLES)
    # after the roles: a run whose demos keep each arm in one role trains (and continues) the per-arm residual
    earlier_state, earlier_memory = (load_earlier(cfg.init_from, rcfg, model.retrieval) if cfg.init_from
                                     else (None, None))
    train = residual_data(rcfg, paths, prior_step, text_encoder, "prior outputs (train)", augmentation,
                          data.augment_copies, optim.seed,
                          build_memory=model.retrieval_threshold if model.retrieval else None, task=data.task,
                          earlier_memory=earlier_memory, samples=samples)
    memory = train.memory
    # "slot_twin"'s and the heading anchor's references: the training demos' mean grasps
    rcfg = replace(rcfg, twin_references=train.twin_references, heading_anchors=train.heading_anchors)
    val = residual_data(rcfg, val_paths, prior_step, text_encoder, "prior outputs (val)",
                        memory=memory, samples=val_samples,
                        role_assigner=assigner) if val_paths else train
    torch.manual_seed(cfg.optim.seed)  # here, so how the prior was obtained cannot change the residual's init
    residual = ResidualPolicy(rcfg, SkillBasis.from_verbs(text_encoder))
    if earlier_state is not None:
        residual.load_state_dict(earlier_state)  # with the earlier task's input statistics: kept, not refit
        reset_output_scale(residual)  # the earlier task's factors are chosen again for this one
    elif rcfg.normalise_inputs:
        residual.fit_normalisation(train.inputs)
    optimizer = make_optimizer(cfg.optim.optimizer, residual.parameters(), lr=cfg.optim.lr)
    checkpoint_meta = {"prior": cfg.prior, "use_projection": cfg.model.use_projection, "segmenter": cfg.model.segmenter,
                       "retrieval": cfg.model.retrieval,
                       "segmenter_options": segmenter_options(cfg.model.grounding_dino, cfg.model.sam),
                       "task": cfg.dataset.task, "demos": len(paths), "train_config": asdict(cfg),
                       "text_encoder": cfg.model.text_encoder, "prior_instruction": prior_step.prior_instruction,
                       "instruction_chooser": (prior_step.instruction_chooser.to_dict()
                                               if prior_step.instruction_chooser else None),
                       "role_assigner": assigner.to_dict() if assigner else None}

    weights = LossWeights(cfg.beta, cfg.gripper_weight, cfg.hold_weight)

    def step_fn(step: int, gen: torch.Generator) -> dict[str, torch.Tensor]:
        batch = train.rows(torch.randint(len(train.inputs), (cfg.optim.batch_size,), generator=gen))
        return bc_loss(residual(batch.inputs), batch, weights)

    def validate(step: int) -> dict[str, float]:
        return validation_losses(residual, val, weights, cfg.select_by)

    def on_best(step: int, value: float, elapsed_s: float) -> None:
        save_residual(out / "best", residual, {**checkpoint_meta, "trained_steps": step, "validation_loss": value},
                      memory)

    def on_validated(step: int, value: float) -> None:  # --select-rollouts: the candidates the rollouts compare
        keep_candidate(out, step, value, cfg.select_candidates, optim.steps, lambda folder: save_residual(
            folder, residual, {**checkpoint_meta, "trained_steps": step, "validation_loss": value}, memory))

    def gate(folder: Path) -> dict[str, Any]:
        """Choose the output gate's scales for the checkpoint in ``folder`` on the validation demos and save them
        into it; leaves ``residual`` holding that checkpoint."""
        residual.load_state_dict(load_safetensors(folder / "model.safetensors"))
        if not rcfg.output_gate:
            return {}
        reset_output_scale(residual)
        ungated = translation_report(residual, val)
        chosen = {"output_gate": {**choose_output_scale(residual, val.inputs, val.translation, val.rotation),
                                  "validation_translation_error_ungated": ungated}}
        saved = json.loads((folder / "config.json").read_text())
        meta = {k: v for k, v in saved.items() if k not in ("type", "residual")}
        save_residual(folder, residual, {**meta, "output_scale": chosen["output_gate"]}, memory)
        return chosen

    with open_logger(optim.log, out, asdict(cfg)) as logger:
        result = run_training(out, residual, optimizer, optim.steps, step_fn, optim.seed, optim.checkpoint_every,
                              validate, on_best, desc="train residual", patience=optim.patience, logger=logger,
                              lr_factor=lambda step: lr_factor(optim.schedule, step, optim.steps, optim.warmup_steps),
                              on_validated=on_validated if cfg.select_rollouts else None)
        gated: dict[str, Any] = {}
        choice: dict[str, Any] = {}
        if cfg.select_rollouts:  # every candidate gated as best/ would be, then rolled out; the winner is best/
            for folder in candidate_folders(out):
                if "output_scale" not in json.loads((folder / "config.json").read_text()):
                    gate(folder)
            choice = {"closed_loop_choice": choose_by_rollouts(out, data.task, cfg.select_rollouts,
                                                               cfg.select_workers, cfg.select_max_keyframes)}
            residual.load_state_dict(load_safetensors(out / "best" / "model.safetensors"))
            saved_gate = json.loads((out / "best" / "config.json").read_text()).get("output_scale")
            gated = {"output_gate": saved_gate} if saved_gate else {}
            logger.scalars(optim.steps, {"closed_loop_choice": {
                "chosen_step": choice["closed_loop_choice"]["chosen_step"]}})
        elif (out / "best" / "model.safetensors").is_file():  # report on the checkpoint the run hands on
            gated = gate(out / "best")
            if gated:
                logger.scalars(optim.steps, gated)  # the gate's choice: the scale kept per output, and its errors
    atomic_write_json(out / "summary.json", {**result, "wall_time_s": round(time.time() - started, 1),
                                             "train_samples": len(train.inputs),
                                             "validation_translation_error": translation_report(residual, val),
                                             "validation_rotation_error": rotation_report(residual, val),
                                             **gated, **choice, **instruction_choice,
                                             **({"roles": roles} if roles else {})})
    return out / "best"
