"""Pretraining a unimanual prior on single-arm demonstrations only (`bimanualshift pretrain --prior peract|dp`).

One loop serves every registered prior: batches hold continuous arm-frame action chunks, the SE(3)
augmentation moves voxels, proprioception and actions together, and each prior turns the chunk into its own
objective (``UnimanualPrior.compute_loss``). Checkpoints are written atomically every ``checkpoint_every``
steps and an interrupted run resumes from its newest one; validation seeds (never test seeds) pick the
shipped checkpoint.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict
from pathlib import Path

import torch

from bimanualshift.data.episode import list_episodes, read_episode
from bimanualshift.encoders.text import default_text_encoder
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.arm_samples import ArmSamples, action_chunks, build_arm_samples
from bimanualshift.perception.observation import ArmObservationBuilder
from bimanualshift.priors import UnimanualPrior
from bimanualshift.priors.base import PRIORS, prior_type, resolve_prior_path
from bimanualshift.priors.base import build_prior as build_prior_network
from bimanualshift.sim.task_registry import resolve_task_names, task_names
from bimanualshift.training.augment import (
    Se3Augmentation,
    sample_motion,
    transform_points,
    transform_poses,
    transform_quats,
    transform_scene,
)
from bimanualshift.training.configs import PretrainConfig
from bimanualshift.training.distributed import Distributed, init_distributed, loss_module
from bimanualshift.training.keyframe_errors import validation_summary
from bimanualshift.training.loop import run_training
from bimanualshift.training.metric_log import open_logger
from bimanualshift.training.optim import lr_factor, make_optimizer
from bimanualshift.utils.config_files import read_json_file
from bimanualshift.utils.io import atomic_write_json, atomic_write_text


def build_prior(cfg: PretrainConfig) -> UnimanualPrior:
    return build_prior_network(cfg.network.prior, cfg.network.size, cfg.network.model)


class PriorBatches:
    """Samples, their action chunks and instruction embeddings, served as (augmented) training batches."""

    def __init__(self, samples: ArmSamples, grid: VoxelGrid, horizon: int, extra_poses: tuple[int, ...] = ()
                 ) -> None:
        self.samples = samples
        self.grid = grid
        self.extra_poses = extra_poses  # where further poses (position, quaternion) start in the proprio
        chunks = action_chunks(samples, horizon)
        self.actions = {k: torch.as_tensor(v) for k, v in chunks.items()}
        # a point-cloud prior's observation replaces the voxels in its batches (its samples hold no voxels)
        self.voxels = torch.as_tensor(samples.voxels) if samples.voxels is not None else None
        self.points = torch.as_tensor(samples.points) if samples.points is not None else None
        self.proprio = torch.as_tensor(samples.proprio)
        self.text = torch.as_tensor(default_text_encoder().encode(samples.instructions))

    def __len__(self) -> int:
        return len(self.samples)

    def batch(self, index: torch.Tensor, generator: torch.Generator | None = None,
              augmentation: Se3Augmentation | None = None
              ) -> tuple[tuple[torch.Tensor, ...], dict[str, torch.Tensor]]:
        scene = (self.points if self.points is not None else self.voxels)[index].float()
        proprio = self.proprio[index].clone()
        actions = {k: v[index].clone() for k, v in self.actions.items()}
        if generator is not None and augmentation is not None:
            scene, proprio, actions = augment_batch(scene, proprio, actions, self.grid, augmentation, generator,
                                                    self.extra_poses)
        return (scene, proprio, self.text[index]), actions


def augment_batch(scene: torch.Tensor, proprio: torch.Tensor, actions: dict[str, torch.Tensor], grid: VoxelGrid,
                  augmentation: Se3Augmentation, generator: torch.Generator, extra_poses: tuple[int, ...] = ()
                  ) -> tuple[torch.Tensor, torch.Tensor, dict[str, torch.Tensor]]:
    """Move the scene (voxels (B, 4, S, S, S), or a point cloud (B, P, 6)), the gripper's pose in the
    proprioception (and the further poses starting at ``extra_poses``, e.g. the other arm's) and the action chunk
    by one random rigid motion per sample; samples whose targets would leave the grid stay as they were."""
    yaw, translation = sample_motion(augmentation, generator, actions["position"], grid)
    actions = {**actions, "position": transform_points(actions["position"], grid, yaw, translation),
               "quat": transform_quats(actions["quat"], yaw)}
    proprio = transform_poses(proprio, grid, yaw, translation, (0, *extra_poses))
    return transform_scene(scene, grid, yaw, translation), proprio, actions


def global_batch_shard(batches: PriorBatches, index: torch.Tensor, generator: torch.Generator,
                       augmentation: Se3Augmentation | None, ctx: Distributed
                       ) -> tuple[tuple[torch.Tensor, ...], dict[str, torch.Tensor]]:
    """The global batch ``index`` (augmented as one process would), cut to this rank's slice."""
    inputs, actions = batches.batch(index, generator, augmentation)
    if not ctx.enabled:
        return inputs, actions
    mine = ctx.shard(len(index), torch.arange(len(index)))
    return tuple(x[mine] for x in inputs), {k: v[mine] for k, v in actions.items()}


def translation_accuracy(model: UnimanualPrior, batches: PriorBatches, tolerance_m: float = 0.03) -> float:
    """Fraction of keyframes whose predicted position is within ``tolerance_m`` of the expert's."""
    return -validation_summary(model, batches, tolerance_m)["value"]


def episode_seed(path: Path) -> int:
    return int(path.stem.rsplit("_", 1)[1])  # episode_<seed>.h5


def first_demos(paths: list[Path], count: int) -> list[Path]:
    """The ``count`` demos of lowest seed (all of them for 0), so a smaller data volume is a subset of a larger."""
    ordered = sorted(paths, key=episode_seed)
    return ordered[:count] if count else ordered


def seeds_tried(paths: list[Path]) -> int:
    """How many seeds per task a collection tried: one past the highest seed offset on disk (collection keeps
    successes only, so counting files would under-count)."""
    offsets = [int(p.stem.split("_")[-1]) % 100_000 for p in paths]
    return max(offsets) + 1 if offsets else 0


def _first_line(doc: str | None) -> str:
    return (doc or "").strip().split("\n")[0].rstrip(".")


def _shown(path: str) -> str:
    """A path as the card's reader types it: relative to the directory the run was started from, if under it."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd().resolve())) if Path(path).is_absolute() else path
    except ValueError:
        return path


def model_card(cfg: PretrainConfig, kind: str, step: int, accuracy: float, train_episodes: int, val_episodes: int,
               wall_time_s: float, parameters: int, train_seeds: int = 0, val_seeds: int = 0) -> str:
    ds, net, opt = cfg.dataset, cfg.network, cfg.optim
    data, validation_data = _shown(ds.data), _shown(ds.validation_data)
    overrides = f" --model '{json.dumps(net.model)}'" if net.model else ""
    names = resolve_task_names(ds.tasks)
    tasks = " ".join(names)
    augmentation = (f"SE(3): yaw up to {ds.augment_yaw_deg} deg, horizontal shift up to "
                    f"{100 * ds.augment_translation_m:.0f} cm")
    reproduce = "\n".join([
        f"bimanualshift collect --task {tasks} --episodes {train_seeds or train_episodes // len(names)} "
        f"--out {data} --workers 2",
        f"bimanualshift collect --task {tasks} --episodes {val_seeds or val_episodes // len(names)} "
        f"--split validation --out {validation_data} --workers 2",
        f"bimanualshift pretrain --prior {net.prior} --size {net.size} --tasks {tasks} --data {data} "
        f"--validation-data {validation_data} --steps {opt.steps} --batch-size {opt.batch_size} "
        f"--lr {opt.lr} --optimizer {opt.optimizer} --seed {opt.seed} --checkpoint-every {opt.checkpoint_every}"
        f"{overrides}"
        + (f" --schedule {opt.schedule} --warmup-steps {opt.warmup_steps}" if opt.schedule != "constant" else "")
        + (f" --init-from {net.init_from}" if net.init_from else "")
        + (f" --episodes-per-task {ds.episodes_per_task}" if ds.episodes_per_task else ""),
    ])
    what = {"peract": "voxels in the arm's base frame -> translation heat-map, Euler rotation bins, gripper and "
                      "collision (PerAct-style)",
            "diffusion": "the arm's voxels as a point cloud + proprioception + instruction -> a denoised chunk of "
                         "keyframe actions (Diffusion Policy, DDPM training, DDIM inference)",
            "act": "the arm's voxels as a point cloud + proprioception + instruction -> a chunk of keyframe actions "
                   "from a CVAE transformer (ACT)"}.get(kind) or _first_line(PRIORS[kind].__doc__) or kind
    return f"""# Single-arm prior: {kind}

A frozen unimanual prior for BimanualShift: {what}. Trained on **single-arm demonstrations only**.

| | |
|---|---|
| training tasks | {", ".join(names)} |
| training episodes | {train_episodes} successful expert episodes (train seeds from 0, {train_seeds} tried per task) |
| validation episodes | {val_episodes} (validation seeds from 100000, {val_seeds} tried per task; picks it) |
| chosen step | {step} of {opt.steps} (batch {opt.batch_size}, {opt.optimizer} lr {opt.lr}, {augmentation}) |
| parameters | {parameters:,} |
| validation keyframes within 3 cm | {100 * accuracy:.1f} % |
| training time to this step | {wall_time_s / 60:.1f} min (optimisation and validation, after data loading) |

Reproduce:

```bash
{reproduce}
```
"""


def pretrain(cfg: PretrainConfig) -> Path:
    ds, net, opt = cfg.dataset, cfg.network, cfg.optim
    started = time.time()
    kind = prior_type(net.prior)
    out = Path(cfg.out)
    ctx = init_distributed()  # one process, or one of torchrun's
    if ctx.is_main:
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_json(out / "config.json", asdict(cfg))
    torch.manual_seed(opt.seed)
    model = UnimanualPrior.from_pretrained(net.init_from, net.model) if net.init_from else build_prior(cfg)
    if net.init_from and model.config.type != kind:
        raise ValueError(f"init_from={net.init_from!r} is a {model.config.type} prior, not {kind}: pass its type "
                         f"with --prior {model.config.type}")
    prior_cfg = model.config
    grid = VoxelGrid(tuple(prior_cfg.bounds), prior_cfg.voxel_size)
    builder = ArmObservationBuilder(grid, points=model.cloud_points, voxels=model.observation == "voxels")
    tasks = resolve_task_names(ds.tasks)
    bimanual = [t for t in tasks if t in task_names(bimanual=True)]
    if bimanual:
        raise ValueError(f"{bimanual} are bimanual tasks: priors are pretrained on single-arm tasks only")
    missing = [t for t in tasks if not list_episodes(ds.data, t)]
    if missing:
        raise FileNotFoundError(f"no single-arm demos for {missing} under {ds.data}; run "
                                f"`bimanualshift collect --task {' '.join(missing)} --episodes N --out {ds.data}` "
                                "first, or pass --tasks with the tasks you have")
    if ds.episodes_per_task < 0:
        raise ValueError(f"--episodes-per-task must be >= 0 (0 uses every demo), got {ds.episodes_per_task}")
    paths = [p for t in tasks for p in first_demos(list_episodes(ds.data, t), ds.episodes_per_task)]
    for p in paths[:1]:
        if read_episode(p).arm_names != ["right"]:
            raise ValueError(f"{p} is not a single-arm episode: priors are pretrained on single-arm data only")
    max_keyframes = model.config.max_keyframes
    train = PriorBatches(build_arm_samples(paths, builder, max_keyframes, desc="voxelise train"), grid,
                         model.action_horizon)
    val_paths = [p for t in tasks for p in list_episodes(ds.validation_data, t)]
    val = (PriorBatches(build_arm_samples(val_paths, builder, max_keyframes, desc="voxelise val"), grid,
                        model.action_horizon) if val_paths else None)
    if not net.init_from:  # a continued prior keeps the normalisation its weights were trained with
        model.set_normalization(train.actions["position"].reshape(-1, 3))
    optimizer = make_optimizer(opt.optimizer, model.parameters(), opt.lr)
    augmentation = (Se3Augmentation(ds.augment_translation_m, ds.augment_yaw_deg)
                    if ds.augment_translation_m > 0 or ds.augment_yaw_deg > 0 else None)

    losses = loss_module(model, ctx)

    def step_fn(step: int, gen: torch.Generator) -> dict[str, torch.Tensor]:
        index = torch.randint(len(train), (opt.batch_size,), generator=gen)
        return losses(*global_batch_shard(train, index, gen, augmentation, ctx), gen)

    def validate(step: int) -> dict[str, float]:
        return validation_summary(model, val if val is not None else train)

    # a continued prior's training time and steps include the runs that built its starting point
    earlier = read_json_file(resolve_prior_path(net.init_from) / "config.json") if net.init_from else {}
    earlier_s, earlier_steps = float(earlier.get("training_time_s") or 0.0), int(earlier.get("trained_steps") or 0)

    def on_best(step: int, value: float, elapsed_s: float) -> None:
        model.save_pretrained(out / "best", extra={
            "trained_steps": earlier_steps + step, "validation_translation_accuracy": -value,
            "pretrain_tasks": tasks, "train_episodes": len(paths), "training_time_s": earlier_s + elapsed_s,
            "initialised_from": net.init_from or None,
        })
        atomic_write_text(out / "best" / "README.md", model_card(
            cfg, kind, step, -value, len(paths), len(val_paths), earlier_s + elapsed_s,
            sum(p.numel() for p in model.parameters()), seeds_tried(paths), seeds_tried(val_paths)))

    with open_logger(opt.log if ctx.is_main else "none", out, asdict(cfg)) as logger:
        result = run_training(out, model, optimizer, opt.steps, step_fn, opt.seed, opt.checkpoint_every,
                              validate, on_best, desc=f"pretrain {kind}", ctx=ctx, logger=logger,
                              lr_factor=lambda step: lr_factor(opt.schedule, step, opt.steps, opt.warmup_steps))
    summary = {**result, "wall_time_s": round(time.time() - started, 1), "train_samples": len(train),
               "processes": ctx.world_size}
    if ctx.is_main:
        atomic_write_json(out / "summary.json", summary)
    return out / "best"
