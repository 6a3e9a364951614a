"""Training prior networks (PerAct-style or Diffusion Policy) on bimanual demos, for the baselines that
fine-tune or train a backbone (the from-scratch bimanual policies, the leader-follower pairs).

The same networks, losses, SE(3) augmentation (every pose in the proprioception moves with the scene),
optimiser and resumable loop as prior pretraining; validation keyframes within 3 cm pick the checkpoint.
What differs per baseline is which arms' samples train the network, what its proprioception holds, and where
it starts from (random weights, or a single-arm prior whose proprioception layer is widened with zero weights,
so the fine-tuning starts from exactly the prior's behaviour).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import torch

from bimanualshift.data.episode import list_episodes, read_episode
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.methods.registry import TrainRequest
from bimanualshift.perception.observation import ArmObservationBuilder
from bimanualshift.priors.base import UnimanualPrior
from bimanualshift.training.augment import Se3Augmentation
from bimanualshift.training.distributed import init_distributed, loss_module
from bimanualshift.training.loop import run_training
from bimanualshift.training.optim import make_optimizer
from bimanualshift.training.pretrain import (
    PretrainConfig,
    PriorBatches,
    build_prior,
    global_batch_shard,
    translation_accuracy,
)
from bimanualshift.training.samples import ArmSamples, build_arm_samples
from bimanualshift.utils.io import atomic_write_json

OWN_PROPRIO = 8  # position, quaternion, gripper opening (the keyframe fraction comes last, after any extras)

# (samples of every arm, their episodes' arm frames) -> extra proprioception columns (N, E)
ExtraProprio = Callable[[ArmSamples, list[dict[str, ArmFrame]]], np.ndarray]


@dataclass(frozen=True)
class VoxelNetworkSpec:
    name: str
    arms: tuple[str, ...]  # whose samples train this network
    extra_dim: int  # proprioception values added after the arm's own 8
    extra_proprio: ExtraProprio | None = None
    extra_poses: tuple[int, ...] = ()  # where poses (position, quaternion) start among the extras
    init_from_prior: bool = False  # start from the request's prior, or from random weights
    kind: str = "peract"  # the network: peract or diffusion (a fine-tuned prior must be of this kind)
    build: Callable[[UnimanualPrior | None, int, str], UnimanualPrior] | None = None  # (prior, extra_dim, size)


def with_extra_proprio(samples: ArmSamples, extra: np.ndarray) -> ArmSamples:
    """Insert ``extra`` columns between the arm's own proprio and the keyframe fraction."""
    proprio = np.concatenate([samples.proprio[:, :OWN_PROPRIO], extra, samples.proprio[:, OWN_PROPRIO:]], axis=1)
    return replace(samples, proprio=proprio.astype(np.float32))


def select_arms(samples: ArmSamples, arms: tuple[str, ...]) -> ArmSamples:
    keep = np.flatnonzero([a in arms for a in samples.arm])
    return ArmSamples(**{k: ([v[i] for i in keep] if isinstance(v, list) else v if v is None else v[keep])
                         for k, v in vars(samples).items()})


def widen_from_prior(model: UnimanualPrior, prior: UnimanualPrior, extra_dim: int) -> None:
    """Copy the prior's weights; the wider proprioception layer gets zero weights for the extra columns. Modules
    ``model`` has beyond the prior's keep their own initialisation."""
    key = type(prior).proprio_weight
    if not key or key != type(model).proprio_weight:
        raise ValueError(f"cannot widen a {type(prior).__name__} into a {type(model).__name__}")
    state = {k: v.clone() for k, v in prior.state_dict().items()}
    old = state[key]  # (dim, OWN_PROPRIO [+ extras] + 1)
    width = model.state_dict()[key].shape[1]
    if old.shape[1] != width:  # a single-arm prior: widen; an earlier network of this kind already fits
        new = torch.zeros(old.shape[0], width)
        new[:, :OWN_PROPRIO] = old[:, :OWN_PROPRIO]
        new[:, -1] = old[:, -1]  # the keyframe fraction
        state[key] = new
    unexpected = model.load_state_dict(state, strict=False).unexpected_keys
    if unexpected:
        raise ValueError(f"the prior has weights this network lacks: {unexpected}")


def build_widened(prior: UnimanualPrior | None, extra_dim: int, size: str, kind: str = "peract") -> UnimanualPrior:
    """A network of ``kind`` reading ``extra_dim`` more proprio values: the prior's architecture and weights
    (widened), or a fresh network of the named size."""
    overrides = {"proprio_dim": OWN_PROPRIO + extra_dim}
    if prior is not None:
        overrides = {**asdict(prior.config), **overrides}
        prior_extra = prior.config.proprio_dim - OWN_PROPRIO
        if prior_extra not in (0, extra_dim):
            raise ValueError(f"cannot start a network reading {extra_dim} extra proprio values from one reading "
                             f"{prior_extra}")
    model = build_prior(PretrainConfig(prior=prior.config.type if prior is not None else kind, size=size,
                                       model=overrides))
    if prior is not None:
        widen_from_prior(model, prior, extra_dim)
    return model


def arm_frames_of(paths: list[Path]) -> list[dict[str, ArmFrame]]:
    frames = []
    for path in paths:
        episode = read_episode(path)
        frames.append({arm: ArmFrame(tuple(base)) for arm, base in episode.arm_bases.items()})
    return frames


def _batches(spec: VoxelNetworkSpec, paths: list[Path], builder: ArmObservationBuilder, grid: VoxelGrid,
             horizon: int, desc: str) -> PriorBatches:
    samples = build_arm_samples(paths, builder, desc=desc)
    if spec.extra_proprio is not None:
        samples = with_extra_proprio(samples, spec.extra_proprio(samples, arm_frames_of(paths)))
    samples = select_arms(samples, spec.arms)
    if not len(samples):
        raise ValueError(f"no samples of arm(s) {spec.arms} in {len(paths)} episodes")
    return PriorBatches(samples, grid, horizon, extra_poses=tuple(OWN_PROPRIO + p for p in spec.extra_poses))


def train_voxel_network(spec: VoxelNetworkSpec, request: TrainRequest, out: Path, size: str = "default",
                        lr: float = 1e-3, batch_size: int = 4, checkpoint_every: int = 250,
                        optimizer: str = "lamb") -> Path:
    started = time.time()
    ctx = init_distributed()  # one process, or one of torchrun's
    out.mkdir(parents=True, exist_ok=True)
    paths = list_episodes(request.data, request.task)[: request.demos]
    if not paths:
        raise FileNotFoundError(f"no bimanual demos for {request.task} under {request.data}; collect them with "
                                f"`bimanualshift collect --task {request.task} --out {request.data}`")
    torch.manual_seed(request.seed)
    prior = UnimanualPrior.from_pretrained(request.prior) if spec.init_from_prior else None
    if prior is not None and prior.config.type != spec.kind:
        raise ValueError(f"{spec.name} fine-tunes a {spec.kind} prior; {request.prior} is a {prior.config.type}")
    model = spec.build(prior, spec.extra_dim, size) if spec.build else build_widened(prior, spec.extra_dim, size,
                                                                                     spec.kind)
    grid = VoxelGrid(tuple(model.config.bounds), model.config.voxel_size)
    builder = ArmObservationBuilder(grid)  # the global scene: no arm-conditioned projection
    train = _batches(spec, paths, builder, grid, model.action_horizon, f"voxelise train ({spec.name})")
    val_paths = list_episodes(request.validation_data, request.task)
    val = _batches(spec, val_paths, builder, grid, model.action_horizon, "voxelise val") if val_paths else train
    if prior is None:  # a fine-tuned prior keeps its own normalisation
        model.set_normalization(train.actions["position"].reshape(-1, 3))
    optimiser = make_optimizer(optimizer, model.parameters(), lr=lr)
    augmentation = Se3Augmentation(PretrainConfig.augment_translation_m, PretrainConfig.augment_yaw_deg)
    if ctx.is_main:
        atomic_write_json(out / "train_config.json", {
            "network": spec.name, "kind": spec.kind, "request": asdict(request), "size": size, "lr": lr,
            "batch_size": batch_size, "optimizer": optimizer})

    losses = loss_module(model, ctx)

    def step_fn(step: int, gen: torch.Generator) -> dict[str, torch.Tensor]:
        index = torch.randint(len(train), (batch_size,), generator=gen)
        return losses(*global_batch_shard(train, index, gen, augmentation, ctx), gen)

    def validate(step: int) -> float:
        return -translation_accuracy(model, val)

    def on_best(step: int, value: float, elapsed_s: float) -> None:
        model.save_pretrained(out / "best", extra={"network": spec.name, "task": request.task, "demos": len(paths),
                                                   "trained_steps": step, "initialised_from": request.prior
                                                   if prior is not None else None,
                                                   "validation_translation_accuracy": -value})

    result = run_training(out, model, optimiser, request.steps, step_fn, request.seed, checkpoint_every, validate,
                          on_best, desc=f"train {spec.name}", ctx=ctx)
    if ctx.is_main:
        atomic_write_json(out / "summary.json", {**result, "wall_time_s": round(time.time() - started, 1),
                                                 "train_samples": len(train), "processes": ctx.world_size})
    return out / "best"
