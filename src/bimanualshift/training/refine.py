"""Retrieval-conditioned residual refinement (paper §III-C, Eq. 10-11, 13): `bimanualshift refine`.

1. Roll the trained policy out on training scenes (train-split seeds, never test), and with
   ``validation_episodes`` on validation scenes too: those only pick the fine-tuning step (5.).
2. A success is a verified execution: it goes into the memory bank M.
3. A failure is replayed from the same scene with the scripted expert as the human corrector: at every
   keyframe where an arm's action strays from the expert's (beyond a position / angle tolerance, a half turn
   about the gripper's approach axis counting as none, or the gripper disagrees) the expert's action for that
   arm is executed instead, and the step becomes a correction sample with target r* = a_corr - a_base
   (Eq. 10), a_base being the frozen prior's action. A corrected run that succeeds is inserted into M as well.
4. The residual branch (Manager, Z, G) is fine-tuned on L_BC over the demos + lambda * L_corr over the
   correction samples (Eq. 11, 13); the prior and the projection stay frozen.
5. The fine-tuning step handed on is the one with the lowest validation loss: the validation demos' L_BC, plus
   lambda times the validation scenes' corrections' when there are any (step 0, the trained weights, competes).

Rollouts are checkpointed per scene (a killed run keeps the scenes it finished) and the fine-tuning uses
the shared resumable loop.
"""

from __future__ import annotations

import json
import shutil
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from safetensors import safe_open
from safetensors.torch import save_file
from tqdm import tqdm

from bimanualshift.data.episode import list_episodes
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.data.seeds import split_seeds
from bimanualshift.encoders.text import TextEncoder
from bimanualshift.geometry.frames import gripper_angle_deg
from bimanualshift.memory.bank import MemoryBank, MemoryEntry
from bimanualshift.methods.bimanualshift import MEMORY_FILE, BimanualShift, load_bimanualshift, save_residual
from bimanualshift.residual.manager import ResidualConfig, arm_and_slot
from bimanualshift.residual.output_gate import choose_output_scale, reset_output_scale
from bimanualshift.rollout.loop import rollout
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.training.augment import Se3Augmentation
from bimanualshift.training.configs import RefineConfig, TrainConfig
from bimanualshift.training.loop import run_training
from bimanualshift.training.metric_log import open_logger
from bimanualshift.training.optim import make_lamb
from bimanualshift.training.residual_data import (
    TARGET_FIELDS,
    ResidualData,
    action_space_targets,
    repeats,
    residual_data,
    rotation_target,
)
from bimanualshift.training.residual_losses import LossWeights, bc_loss, validation_losses
from bimanualshift.utils.config_files import config_from_dict, load_safetensors, read_json_file
from bimanualshift.utils.io import atomic_write_json, atomic_writer
from bimanualshift.utils.workers import run_jobs


@dataclass
class Correction:
    inputs: list[torch.Tensor]
    translation: list[np.ndarray]
    rotation: list[np.ndarray]
    gripper: list[float]  # the corrector's gripper (1 open)
    hold: list[float]  # 1 where the corrector repeats the arm's previous action (it waits)
    # an action-space residual's targets (ResidualData's fields of the same names), one row per correction
    action_space: dict[str, list[torch.Tensor]] = field(default_factory=dict)


def arm_frame_action(decision_frame: Any, row: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A world-frame action row's position and quaternion in the arm's frame."""
    return decision_frame.pose_to_arm(row[:3], row[3:7])


def strays(policy_row: np.ndarray, expert_row: np.ndarray, tolerance_m: float, tolerance_deg: float) -> bool:
    """Whether one arm's world-frame action differs from the corrector's beyond the tolerances. A gripper turned
    a half turn about its approach axis holds the same grasp (its two fingers are alike), so that alone is no
    failure to correct: the same test ``bimanualshift explain`` applies."""
    position = np.linalg.norm(policy_row[:3] - expert_row[:3]) > tolerance_m
    angle = gripper_angle_deg(policy_row[3:7], expert_row[3:7]) > tolerance_deg
    gripper = (policy_row[7] > 0.5) != (expert_row[7] > 0.5)
    return bool(position or angle or gripper)


def _trajectory_row(decisions: list, executed: np.ndarray) -> np.ndarray:
    """(A, 8) the executed actions in each arm's frame: position, quaternion, gripper (the bank's format)."""
    rows = []
    for d, row in zip(decisions, executed):
        pos, quat = arm_frame_action(d.step.frame, row)
        rows.append(np.r_[pos, quat, row[7]])
    return np.asarray(rows, np.float32)


def twin_reference(config: ResidualConfig, inputs: torch.Tensor) -> np.ndarray | None:
    """The "slot_twin" reference grasp of a Manager input row's arm and keyframe slot (None for other targets)."""
    if config.rotation_target != "slot_twin":
        return None
    arm, slot = arm_and_slot(config, inputs.reshape(1, -1))
    return config.twin_reference(int(arm[0]), int(slot[0]))


def run_policy(env: ManipulationEnv, policy: BimanualShift, seed: int, max_keyframes: int,
               corrector: list[np.ndarray] | None = None, tolerance_m: float = 0.03, tolerance_deg: float = 20.0,
               ) -> tuple[bool, np.ndarray, np.ndarray | None, Correction]:
    """One episode; with ``corrector`` (the expert's world-frame actions per keyframe) straying arms are
    overridden and recorded. Returns (success, executed arm-frame trajectory, memory key, corrections)."""
    trajectory, correction = [], Correction([], [], [], [], [])

    def act(k: int, obs: KeyframeObservation) -> np.ndarray:
        decisions = policy.decide(obs)
        executed = np.stack([d.action for d in decisions])
        if corrector is not None:
            for i, d in enumerate(decisions):
                expert = corrector[k][i]
                if not strays(d.action, expert, tolerance_m, tolerance_deg):
                    continue
                executed[i] = expert
                pos, quat = arm_frame_action(d.step.frame, expert)
                base = d.step.prior  # Eq. 10: the target is relative to the frozen prior's action
                correction.inputs.append(d.inputs)
                correction.translation.append(pos - base.position[0].numpy())
                correction.rotation.append(rotation_target(policy.residual.config, quat, base.quat[0].numpy(),
                                                           twin_reference(policy.residual.config, d.inputs)))
                correction.gripper.append(float(expert[7] > 0.5))
                correction.hold.append(float(k > 0 and repeats(expert, corrector[k - 1][i])))
                if policy.residual.config.action_space:  # Eq. 10 in the prior's own action space
                    targets = action_space_targets(policy.prior_step.prior, base, policy.residual.config,
                                                   torch.as_tensor(pos, dtype=torch.float32)[None], quat[None])
                    for name, value in targets.items():
                        correction.action_space.setdefault(name, []).append(value[0])
        trajectory.append(_trajectory_row(decisions, executed))
        return executed

    steps = len(corrector) if corrector is not None else max_keyframes
    record = rollout(env, policy, seed, steps, act=act)
    success = bool(record.success or env.success())
    return success, np.stack(trajectory), policy.first_key(), correction


def expert_actions(env: ManipulationEnv, seed: int) -> list[np.ndarray]:
    """The scripted expert's world-frame action rows for a scene, planned from its initial state."""
    env.reset(seed=seed)
    return [env.action_from_keyframe(k) for k in env.expert_keyframes()]


def _save_scene(path: Path, record: dict, correction: Correction, trajectory: np.ndarray | None,
                key: np.ndarray | None) -> None:
    tensors = {"inputs": torch.stack(correction.inputs) if correction.inputs else torch.zeros(0),
               "translation": torch.as_tensor(np.asarray(correction.translation, np.float32)),
               "rotation": torch.as_tensor(np.asarray(correction.rotation, np.float32)),
               "gripper": torch.as_tensor(np.asarray(correction.gripper, np.float32)),
               "hold": torch.as_tensor(np.asarray(correction.hold, np.float32)),
               **{name: torch.stack(rows) for name, rows in correction.action_space.items()}}
    if trajectory is not None and key is not None:
        tensors["trajectory"] = torch.as_tensor(trajectory)
        tensors["key"] = torch.as_tensor(np.asarray(key, np.float32))
    with atomic_writer(path) as tmp:
        save_file({k: v.contiguous() for k, v in tensors.items()}, str(tmp), metadata={"record": json.dumps(record)})


def _refine_scene(env: ManipulationEnv, policy: BimanualShift, cfg: RefineConfig, seed: int, path: Path) -> None:
    """Roll one training scene out, have the expert correct it if it fails, and save it to ``path``."""
    limit = cfg.max_keyframes or env.task.max_keyframes
    success, trajectory, key, correction = run_policy(env, policy, seed, limit)
    record: dict[str, Any] = {"seed": seed, "instruction": env.task.instruction(), "policy_success": success}
    if not success:
        plan = expert_actions(env, seed)
        success, trajectory, key, correction = run_policy(env, policy, seed, len(plan), plan,
                                                          cfg.tolerance_m, cfg.tolerance_deg)
        record["corrected_success"] = success
    record["corrections"] = len(correction.inputs)
    _save_scene(path, record, correction, trajectory if success else None, key)


# A worker process loads the policy once and keeps it for every scene it is given.
_WORKER: dict[str, Any] = {}


def refine_scene_job(job: tuple[dict[str, Any], str, int, str]) -> int:
    """A worker's job: (refine config as a dict, task, seed, scene file). The policy comes from the config's
    checkpoint, as it was before any refinement (the memory grows only after every scene is rolled out)."""
    cfg_dict, task, seed, path = job
    cfg = RefineConfig(**cfg_dict)
    if _WORKER.get("key") != (cfg.checkpoint, task):
        if "env" in _WORKER:
            _WORKER["env"].close()
        _WORKER.update(key=(cfg.checkpoint, task), policy=load_bimanualshift(Path(cfg.checkpoint)),
                       env=ManipulationEnv(task))
    _refine_scene(_WORKER["env"], _WORKER["policy"], cfg, seed, Path(path))
    return seed


# what a scene's rollout depends on: scenes agreeing on these are the same rollouts
ROLLOUT_SETTINGS = ("checkpoint", "episodes", "start", "max_keyframes", "tolerance_m", "tolerance_deg")
# the folders under a refinement's ``out``: training scenes (corrections to learn, successes for the memory) and
# validation scenes (corrections that pick the fine-tuning step)
SCENE_FOLDERS = {"train": "scenes", "validation": "validation_scenes"}


def reuse_scenes(cfg: RefineConfig) -> int:
    """Copy into ``out/scenes`` the finished scenes of ``cfg.scenes_from`` that this refinement lacks; that folder's
    rollouts must come from the same checkpoint and rollout settings. Returns the number copied."""
    source = Path(cfg.scenes_from)
    config = source / "refine_config.json"
    if not config.is_file():
        raise FileNotFoundError(f"--scenes-from {source}: no refine_config.json there; name a folder written by "
                                "`bimanualshift refine`")
    theirs = read_json_file(config)
    differ = [k for k in ROLLOUT_SETTINGS if theirs.get(k) != getattr(cfg, k)]
    if differ:
        raise ValueError(f"--scenes-from {source}: its rollouts differ from this refinement's in {', '.join(differ)} "
                         f"({', '.join(f'{k}={theirs.get(k)!r} there, {getattr(cfg, k)!r} here' for k in differ)}); "
                         "roll the scenes out again without --scenes-from")
    copied = 0
    for split, folder in SCENE_FOLDERS.items():
        if split == "validation" and (theirs.get("validation_start") != cfg.validation_start
                                      or not theirs.get("validation_episodes")):
            continue  # validation scenes are seeded by validation_start; those rolled out elsewhere are others
        scenes = Path(cfg.out) / folder
        scenes.mkdir(parents=True, exist_ok=True)
        wanted = {f"seed_{seed:06d}.safetensors" for seed in _split_scenes(cfg, split)}
        for path in sorted((source / folder).glob("seed_*.safetensors")):
            if path.name in wanted and not (scenes / path.name).is_file():
                with atomic_writer(scenes / path.name) as tmp:
                    shutil.copyfile(path, tmp)
                copied += 1
    return copied


def _split_scenes(cfg: RefineConfig, split: str) -> list[int]:
    if split == "train":
        return split_seeds("train", cfg.episodes, cfg.start)
    return split_seeds("validation", cfg.validation_episodes, cfg.validation_start)


def collect_refinement(cfg: RefineConfig, policy: BimanualShift, task: str, in_process: bool = False
                       ) -> dict[str, list[Path]]:
    """Roll out and correct every scene not yet done; one safetensors file per scene under ``out/scenes`` (training
    scenes) and ``out/validation_scenes``; returns each split's files. Scenes are independent (the policy and its
    memory stay fixed until all are done), so ``cfg.workers`` processes roll them out in parallel with the same
    result as one. Workers rebuild the policy from the checkpoint; ``in_process`` keeps the rollouts on
    ``policy`` itself (one holding parts the checkpoint does not name, such as a caller's own text encoder)."""
    if cfg.scenes_from:
        reuse_scenes(cfg)
    paths: dict[str, list[Path]] = {}
    todo: list[tuple[int, Path]] = []
    for split, folder in SCENE_FOLDERS.items():
        scenes = Path(cfg.out) / folder
        scenes.mkdir(parents=True, exist_ok=True)
        seeds = _split_scenes(cfg, split)
        paths[split] = [scenes / f"seed_{seed:06d}.safetensors" for seed in seeds]
        todo += [(seed, path) for seed, path in zip(seeds, paths[split]) if not path.is_file()]
    if cfg.workers > 1 and len(todo) > 1 and not in_process:
        jobs = [(asdict(cfg), task, seed, str(path)) for seed, path in todo]
        run_jobs(refine_scene_job, jobs, workers=min(cfg.workers, len(todo)), desc="refinement rollouts",
                 chunksize=1)
        return paths
    env = ManipulationEnv(task)
    for seed, path in tqdm(todo, desc="refinement rollouts", unit="scene"):
        _refine_scene(env, policy, cfg, seed, path)
    env.close()
    return paths


def load_scenes(paths: list[Path]) -> tuple[list[dict], ResidualData | None, list[tuple[dict, np.ndarray, np.ndarray]]]:
    """Per-scene records, the pooled correction samples and the successful executions (record, key, trajectory)."""
    records, parts, successes = [], [], []
    for path in paths:
        with safe_open(str(path), framework="pt") as f:
            record = json.loads(f.metadata()["record"])
            names = set(f.keys())
        tensors = load_safetensors(path)
        records.append(record)
        if record["corrections"]:
            # scenes saved before the coordination targets existed carry none (None: refused by bc_loss if needed)
            parts.append({f: tensors.get(f) for f in ("inputs", "translation", "rotation", *TARGET_FIELDS)})
        if "trajectory" in names:
            successes.append((record, tensors["key"].numpy(), tensors["trajectory"].numpy()))
    data = None
    if parts:
        data = ResidualData(**{f: (None if any(p[f] is None for p in parts) else torch.cat([p[f] for p in parts]))
                               for f in parts[0]})
    return records, data, successes


def refine(cfg: RefineConfig, text_encoder: TextEncoder | None = None) -> Path:
    started = time.time()
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / "refine_config.json", asdict(cfg))
    checkpoint = Path(cfg.checkpoint)
    if not (checkpoint / "config.json").is_file():
        raise FileNotFoundError(f"no BimanualShift checkpoint at {checkpoint}; train one with `bimanualshift train`")
    meta = read_json_file(checkpoint / "config.json")
    if not meta.get("train_config"):
        raise ValueError(f"{checkpoint}/config.json has no train_config; re-train it with this version of "
                         "`bimanualshift train` so refinement can find its demos")
    # the demos it was trained on (a flat train_config of an older checkpoint reads too)
    trained = config_from_dict(TrainConfig, meta["train_config"], checkpoint / "config.json")
    train_cfg = trained.dataset
    policy = load_bimanualshift(checkpoint, text_encoder)
    task = meta["task"]

    # 1-3: rollouts on training scenes, corrections, successes into the (unfrozen) bank.
    # a caller's own text encoder exists only in this process: workers would rebuild the checkpoint's
    scenes = collect_refinement(cfg, policy, task, in_process=text_encoder is not None)
    records, corrections, successes = load_scenes(scenes["train"])
    val_records, val_corrections, _ = load_scenes(scenes["validation"])
    memory = MemoryBank.load(checkpoint / MEMORY_FILE) if policy.memory is not None else None
    inserted = [s for s in successes if cfg.memory_insert == "all"
                or (cfg.memory_insert == "corrected" and s[0].get("corrected_success"))]
    if memory is not None:
        for record, key, trajectory in inserted:
            memory.add(key, trajectory, MemoryEntry(task, record["instruction"], "refinement", int(record["seed"])))

    # 4: fine-tune the residual branch on L_BC (demos) + lambda * L_corr (corrections).
    prior_step, residual = policy.prior_step, policy.residual
    paths = list_episodes(train_cfg.data, task)[: train_cfg.demos]
    if not paths:
        raise FileNotFoundError(f"the demos the checkpoint was trained on are gone: none for {task} under "
                                f"{train_cfg.data}")
    encoder = policy.text_encoder
    augmentation = Se3Augmentation(train_cfg.augment_translation_m, train_cfg.augment_yaw_deg)
    train = residual_data(residual.config, paths, prior_step, encoder, "prior outputs (demos)", augmentation,
                          train_cfg.augment_copies, cfg.seed, memory=memory, own_memory=True)
    val_paths = list_episodes(train_cfg.validation_data, task)
    val = residual_data(residual.config, val_paths, prior_step, encoder, "prior outputs (val)",
                        memory=memory, role_assigner=policy.role_assigner) if val_paths else train
    reset_output_scale(residual)  # fine-tune the whole residual; its factors are chosen again afterwards
    optimizer = make_lamb(residual.parameters(), lr=cfg.lr)
    lambda_corr = cfg.lambda_corr if corrections is not None else 0.0

    # the rotation weight and the checkpoint measure the residual was trained with, unless the refinement sets beta
    weights = LossWeights(cfg.beta or trained.beta, cfg.gripper_weight, cfg.hold_weight)

    def step_fn(step: int, gen: torch.Generator) -> dict[str, torch.Tensor]:
        batch = train.rows(torch.randint(len(train.inputs), (cfg.batch_size,), generator=gen))
        losses = bc_loss(residual(batch.inputs), batch, weights)
        if corrections is None:
            return losses
        fixes = corrections.rows(torch.randint(len(corrections.inputs), (cfg.batch_size,), generator=gen))
        # Eq. 11: || G(v) - r* ||^2 over both components of the residual (and, for the coordination outputs, the
        # cross-entropy against the corrector's gripper and hold), the same form as L_BC.
        corr = bc_loss(residual(fixes.inputs), fixes, weights)["total"]
        return {**losses, "correction": corr, "total": losses["total"] + lambda_corr * corr}

    def validate(step: int) -> dict[str, float]:
        report = validation_losses(residual, val, weights, trained.select_by)
        if val_corrections is None:
            return report
        # Eq. 13 on held-out scenes: the step is picked on how well the residual fits the demos *and* fixes the
        # policy's own failures, each measured as training picks its checkpoint
        held_out = validation_losses(residual, val_corrections, weights, trained.select_by)["value"]
        return {**report, "demos_value": report["value"], "correction_value": held_out,
                "value": report["value"] + cfg.lambda_corr * held_out}

    refine_meta = {**{k: v for k, v in meta.items() if k not in ("type", "residual")},
                   "refined_from": str(checkpoint), "refine_config": asdict(cfg)}

    def on_best(step: int, value: float, elapsed_s: float) -> None:
        save_residual(out / "best", residual, {**refine_meta, "refined_steps": step, "validation_loss": value},
                      memory)

    with open_logger(cfg.log, out, asdict(cfg)) as logger:
        result = run_training(out, residual, optimizer, cfg.steps, step_fn, cfg.seed, cfg.checkpoint_every,
                              validate, on_best, desc="refine residual", logger=logger)
        gate = {}
        if residual.config.output_gate and (out / "best" / "model.safetensors").is_file():
            residual.load_state_dict(load_safetensors(out / "best" / "model.safetensors"))
            reset_output_scale(residual)
            gate = {"output_gate": choose_output_scale(residual, val.inputs, val.translation, val.rotation)}
            logger.scalars(cfg.steps, gate)
            best = read_json_file(out / "best" / "config.json")
            save_residual(out / "best", residual, {**{k: v for k, v in best.items() if k not in ("type", "residual")},
                                                   "output_scale": gate["output_gate"]}, memory)
    summary = {
        **result, "wall_time_s": round(time.time() - started, 1), "scenes": len(records),
        "policy_successes": sum(r["policy_success"] for r in records),
        "corrected_successes": sum(bool(r.get("corrected_success")) for r in records),
        "correction_samples": 0 if corrections is None else len(corrections.inputs),
        "validation_scenes": len(val_records),
        "validation_policy_successes": sum(r["policy_success"] for r in val_records),
        "validation_correction_samples": 0 if val_corrections is None else len(val_corrections.inputs),
        "memory_entries": None if memory is None else len(memory),
        "inserted_into_memory": len(inserted) if memory is not None else 0,
        **gate,
    }
    atomic_write_json(out / "summary.json", summary)
    return out / "best"
