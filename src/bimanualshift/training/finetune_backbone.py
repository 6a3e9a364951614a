"""Training a baseline's backbone network (a PerAct-style, Diffusion Policy or ACT prior network) on bimanual
demos, for the baselines that fine-tune or train a backbone (the from-scratch bimanual policies, the
leader-follower pairs, the AnyBimanual-style network).

The same networks, losses, SE(3) augmentation (every pose in the proprioception moves with the scene),
optimiser and resumable loop as prior pretraining; validation keyframes within 3 cm pick the checkpoint.
What differs per baseline is its ``VoxelNetworkSpec`` (``methods.baselines.network_spec``).
"""

from __future__ import annotations

import time
from dataclasses import asdict
from pathlib import Path

import torch

from bimanualshift.data.episode import list_episodes, read_episode
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.methods.baselines.network_spec import (
    OWN_PROPRIO,
    VoxelNetworkSpec,
    build_widened,
    select_arms,
    with_extra_proprio,
)
from bimanualshift.perception.arm_samples import build_arm_samples
from bimanualshift.perception.observation import ArmObservationBuilder
from bimanualshift.priors.base import UnimanualPrior
from bimanualshift.training.augment import Se3Augmentation
from bimanualshift.training.configs import PriorDataConfig
from bimanualshift.training.distributed import init_distributed, loss_module
from bimanualshift.training.loop import run_training
from bimanualshift.training.metric_log import open_logger
from bimanualshift.training.optim import make_optimizer
from bimanualshift.training.pretrain import (
    PriorBatches,
    global_batch_shard,
    translation_accuracy,
)
from bimanualshift.training.request import TrainRequest
from bimanualshift.utils.io import atomic_write_json


def arm_frames_of(paths: list[Path]) -> list[dict[str, ArmFrame]]:
    frames = []
    for path in paths:
        episode = read_episode(path)
        frames.append({arm: ArmFrame(tuple(base)) for arm, base in episode.arm_bases.items()})
    return frames


def _batches(spec: VoxelNetworkSpec, paths: list[Path], builder: ArmObservationBuilder, model: UnimanualPrior,
             desc: str) -> PriorBatches:
    grid, horizon = builder.grid, model.action_horizon
    samples = build_arm_samples(paths, builder, model.config.max_keyframes, desc=desc,
                                transform=spec.episode_transform)
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
    # the global scene, no arm-conditioned projection; voxels or the cloud, as the network reads
    builder = ArmObservationBuilder(grid, points=model.cloud_points, voxels=model.observation == "voxels")
    train = _batches(spec, paths, builder, model, f"voxelise train ({spec.name})")
    val_paths = list_episodes(request.validation_data, request.task)
    val = _batches(spec, val_paths, builder, model, "voxelise val") if val_paths else train
    if prior is None:  # a fine-tuned prior keeps its own normalisation
        model.set_normalization(train.actions["position"].reshape(-1, 3))
    optimiser = make_optimizer(optimizer, model.parameters(), lr=lr)
    augment = PriorDataConfig()  # the priors' own augmentation
    augmentation = Se3Augmentation(augment.augment_translation_m, augment.augment_yaw_deg)
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

    with open_logger(request.log, out, {"network": spec.name, "task": request.task, "lr": lr}) as logger:
        result = run_training(out, model, optimiser, request.steps, step_fn, request.seed, checkpoint_every,
                              validate, on_best, desc=f"train {spec.name}", ctx=ctx, logger=logger)
    if ctx.is_main:
        atomic_write_json(out / "summary.json", {**result, "wall_time_s": round(time.time() - started, 1),
                                                 "train_samples": len(train), "processes": ctx.world_size})
    return out / "best"
