"""Pretraining a unimanual prior on single-arm demonstrations only (`bimanualshift pretrain`)."""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch

from bimanualshift.data.episode import list_episodes, read_episode
from bimanualshift.encoders.text import default_text_encoder
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.observation import ArmObservationBuilder
from bimanualshift.priors.peract.configuration_peract import PerActConfig
from bimanualshift.priors.peract.modeling_peract import PerActPrior
from bimanualshift.training.augment import random_shift, shift_voxels
from bimanualshift.training.loop import run_training
from bimanualshift.training.optim import make_lamb
from bimanualshift.training.samples import ArmSamples, build_arm_samples, discrete_targets
from bimanualshift.utils.io import atomic_write_json, atomic_write_text


@dataclass
class PretrainConfig:
    tasks: list[str] = field(default_factory=lambda: ["push_button", "pick_cube"])
    data: str = "data/unimanual"
    validation_data: str = "data/unimanual_val"
    out: str = "runs/prior_peract"
    steps: int = 3000
    batch_size: int = 4
    lr: float = 1e-3
    checkpoint_every: int = 250
    augment_max_voxels: int = 2
    seed: int = 0
    prior_type: str = "peract"
    model: dict = field(default_factory=dict)  # overrides of the prior's config fields, e.g. {"dim": 64}


class PriorBatches:
    """Samples tensors, targets and instruction embeddings for prior training."""

    def __init__(self, samples: ArmSamples, config: PerActConfig) -> None:
        grid = VoxelGrid(tuple(config.bounds), config.voxel_size)
        self.samples = samples
        self.grid = grid
        targets = discrete_targets(samples, grid, config.rotation_bin_degrees)
        self.targets = {k: torch.as_tensor(v) for k, v in targets.items()}
        self.voxels = torch.as_tensor(samples.voxels)
        self.proprio = torch.as_tensor(samples.proprio)
        self.text = torch.as_tensor(default_text_encoder().encode(samples.instructions))

    def batch(self, index: torch.Tensor, generator: torch.Generator | None = None, max_shift: int = 0
              ) -> tuple[tuple[torch.Tensor, ...], dict[str, torch.Tensor]]:
        voxels = self.voxels[index].float()
        proprio = self.proprio[index].clone()
        target = {k: v[index].clone() for k, v in self.targets.items()}
        if generator is not None and max_shift > 0:
            s = self.grid.size
            for j in range(len(index)):
                shift = random_shift(generator, max_shift)
                idx = np.array(np.unravel_index(int(target["translation_index"][j]), (s, s, s)))
                moved = idx + shift
                if np.any(moved < 0) or np.any(moved >= s):
                    continue  # the target would leave the grid: keep this sample unshifted
                voxels[j] = shift_voxels(voxels[j], shift)
                target["translation_index"][j] = int(np.ravel_multi_index(moved, (s, s, s)))
                proprio[j, :3] += torch.as_tensor(np.asarray(shift) * self.grid.voxel_size, dtype=torch.float32)
        return (voxels, proprio, self.text[index]), target


def translation_accuracy(model: PerActPrior, batches: PriorBatches, tolerance_m: float = 0.03) -> float:
    """Fraction of validation keyframes whose predicted position is within ``tolerance_m`` of the target."""
    hits = []
    with torch.no_grad():
        for start in range(0, len(batches.samples), 16):
            index = torch.arange(start, min(start + 16, len(batches.samples)))
            inputs, _ = batches.batch(index)
            pred = model.decode_actions(model(*inputs))
            err = np.linalg.norm(pred.position.numpy() - batches.samples.action_pos[index.numpy()], axis=-1)
            hits.extend((err < tolerance_m).tolist())
    return float(np.mean(hits))


def model_card(cfg: PretrainConfig, step: int, accuracy: float, train_episodes: int, val_episodes: int,
               wall_time_s: float) -> str:
    overrides = f" --model '{json.dumps(cfg.model)}'" if cfg.model else ""
    tasks = " ".join(cfg.tasks)
    shifts = f"whole-voxel shifts of up to {cfg.augment_max_voxels} voxels"
    reproduce = "\n".join([
        f"bimanualshift collect --task {tasks} --episodes {train_episodes // len(cfg.tasks)} "
        f"--out {cfg.data} --workers 2",
        f"bimanualshift collect --task {tasks} --episodes {val_episodes // len(cfg.tasks)} --split validation "
        f"--out {cfg.validation_data} --workers 2",
        f"bimanualshift pretrain --data {cfg.data} --validation-data {cfg.validation_data} --steps {cfg.steps} "
        f"--seed {cfg.seed}{overrides}",
    ])
    return f"""# PerAct-style single-arm prior

A frozen unimanual prior for BimanualShift: voxels in the arm's base frame -> translation heat-map,
10-degree Euler rotation bins, gripper and collision. Trained on **single-arm demonstrations only**.

| | |
|---|---|
| training tasks | {", ".join(cfg.tasks)} |
| training episodes | {train_episodes} (scripted expert, train seeds from 0) |
| validation episodes | {val_episodes} (validation seeds from 100000; used to pick this checkpoint) |
| chosen step | {step} of {cfg.steps} (batch {cfg.batch_size}, LAMB lr {cfg.lr}, {shifts}) |
| validation keyframes within 3 cm | {100 * accuracy:.1f} % |
| training time to this step | {wall_time_s / 60:.1f} min (optimisation and validation, after data loading) |

Reproduce:

```bash
{reproduce}
```

## Measured single-arm success

<!-- results:prior_single_arm -->
<!-- /results:prior_single_arm -->

Generated from `results/prior_single_arm.json` by `bimanualshift report --readme <this file>`.
"""


def pretrain(cfg: PretrainConfig) -> Path:
    started = time.time()
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / "config.json", asdict(cfg))
    if cfg.prior_type != "peract":
        raise ValueError(f"unknown prior type {cfg.prior_type!r}; available: peract")
    prior_cfg = PerActConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in cfg.model.items()})
    torch.manual_seed(cfg.seed)
    model = PerActPrior(prior_cfg)
    builder = ArmObservationBuilder(VoxelGrid(tuple(prior_cfg.bounds), prior_cfg.voxel_size))
    paths = [p for t in cfg.tasks for p in list_episodes(cfg.data, t)]
    if not paths:
        raise FileNotFoundError(f"no single-arm demos for {cfg.tasks} under {cfg.data}; run "
                                f"`bimanualshift collect --task <task> --out {cfg.data}` first")
    for p in paths[:1]:
        if read_episode(p).arm_names != ["right"]:
            raise ValueError(f"{p} is not a single-arm episode: priors are pretrained on single-arm data only")
    train = PriorBatches(build_arm_samples(paths, builder, desc="voxelise train"), prior_cfg)
    val_paths = [p for t in cfg.tasks for p in list_episodes(cfg.validation_data, t)]
    val = PriorBatches(build_arm_samples(val_paths, builder, desc="voxelise val"), prior_cfg) if val_paths else None
    optimizer = make_lamb(model.parameters(), lr=cfg.lr)

    def step_fn(step: int, gen: torch.Generator) -> dict[str, torch.Tensor]:
        index = torch.randint(len(train.samples), (cfg.batch_size,), generator=gen)
        inputs, target = train.batch(index, gen, cfg.augment_max_voxels)
        return model.loss(model(*inputs), target)

    def validate(step: int) -> float:
        return -translation_accuracy(model, val if val is not None else train)

    def on_best(step: int, value: float, elapsed_s: float) -> None:
        model.save_pretrained(out / "best", extra={
            "trained_steps": step, "validation_translation_accuracy": -value,
            "pretrain_tasks": cfg.tasks, "train_episodes": len(paths),
        })
        atomic_write_text(out / "best" / "README.md", model_card(cfg, step, -value, len(paths), len(val_paths),
                                                               elapsed_s))

    result = run_training(out, model, optimizer, cfg.steps, step_fn, cfg.seed, cfg.checkpoint_every,
                          validate, on_best, desc="pretrain")
    summary = {**result, "wall_time_s": round(time.time() - started, 1), "train_samples": len(train.samples)}
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    return out / "best"
