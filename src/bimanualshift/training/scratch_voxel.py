"""Training the from-scratch bimanual voxel baseline (methods/baselines/scratch_voxel.py) on bimanual demos.

The same network, losses, SE(3) augmentation (the other arm's pose moves with the scene), LAMB and resumable
loop as prior pretraining, but from random weights, on the bimanual demos of one task, with both arms'
samples and the extended proprioception. Validation keyframes within 3 cm pick the checkpoint.
"""

from __future__ import annotations

import time
from dataclasses import asdict, replace
from pathlib import Path

import torch

from bimanualshift.data.episode import list_episodes
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.methods.baselines.scratch_voxel import EXTRA_PROPRIO, OWN_PROPRIO, bimanual_proprio
from bimanualshift.methods.registry import TrainRequest
from bimanualshift.perception.observation import ArmObservationBuilder
from bimanualshift.training.augment import Se3Augmentation
from bimanualshift.training.loop import run_training
from bimanualshift.training.optim import make_lamb
from bimanualshift.training.pretrain import PretrainConfig, PriorBatches, build_prior, translation_accuracy
from bimanualshift.training.samples import ArmSamples, build_arm_samples
from bimanualshift.utils.io import atomic_write_json


def _bimanual_batches(paths: list[Path], builder: ArmObservationBuilder, grid: VoxelGrid, horizon: int, desc: str
                      ) -> PriorBatches:
    samples = build_arm_samples(paths, builder, desc=desc)
    samples: ArmSamples = replace(samples, proprio=bimanual_proprio(samples.proprio, samples.other_proprio,
                                                                    samples.arm))
    return PriorBatches(samples, grid, horizon, extra_poses=(OWN_PROPRIO,))


def train_scratch_voxel(request: TrainRequest, size: str = "default", lr: float = 1e-3, batch_size: int = 4,
                        checkpoint_every: int = 250) -> Path:
    started = time.time()
    out = Path(request.out)
    out.mkdir(parents=True, exist_ok=True)
    paths = list_episodes(request.data, request.task)[: request.demos]
    if not paths:
        raise FileNotFoundError(f"no bimanual demos for {request.task} under {request.data}")
    cfg = PretrainConfig(prior="peract", size=size, steps=request.steps, batch_size=batch_size, lr=lr,
                         seed=request.seed, model={"proprio_dim": OWN_PROPRIO + EXTRA_PROPRIO})
    torch.manual_seed(cfg.seed)
    model = build_prior(cfg)
    grid = VoxelGrid(tuple(model.config.bounds), model.config.voxel_size)
    builder = ArmObservationBuilder(grid)  # the global scene: no arm-conditioned projection
    train = _bimanual_batches(paths, builder, grid, model.action_horizon, "voxelise train")
    val_paths = list_episodes(request.validation_data, request.task)
    val = _bimanual_batches(val_paths, builder, grid, model.action_horizon, "voxelise val") if val_paths else train
    model.set_normalization(train.actions["position"].reshape(-1, 3))
    optimizer = make_lamb(model.parameters(), lr=cfg.lr)
    augmentation = Se3Augmentation(cfg.augment_translation_m, cfg.augment_yaw_deg)
    atomic_write_json(out / "train_config.json", {"method": "scratch_voxel", "request": asdict(request),
                                                 "size": size, "lr": lr, "batch_size": batch_size})

    def step_fn(step: int, gen: torch.Generator) -> dict[str, torch.Tensor]:
        index = torch.randint(len(train), (cfg.batch_size,), generator=gen)
        inputs, actions = train.batch(index, gen, augmentation)
        return model.compute_loss(inputs, actions, gen)

    def validate(step: int) -> float:
        return -translation_accuracy(model, val)

    def on_best(step: int, value: float, elapsed_s: float) -> None:
        model.save_pretrained(out / "best", extra={"method": "scratch_voxel", "task": request.task,
                                                   "demos": len(paths), "trained_steps": step,
                                                   "validation_translation_accuracy": -value})

    result = run_training(out, model, optimizer, request.steps, step_fn, cfg.seed, checkpoint_every, validate,
                          on_best, desc="train scratch voxel policy")
    atomic_write_json(out / "summary.json", {**result, "wall_time_s": round(time.time() - started, 1),
                                             "train_samples": len(train)})
    return out / "best"
