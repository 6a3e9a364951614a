"""Commands on the simulated tasks themselves: list them, collect demos, check the experts, pictures, videos."""

from __future__ import annotations

import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from bimanualshift.cli.common import command_line, resolve_tasks


@dataclass
class TasksArgs:
    """List the registered tasks (your own too, with --plugin)."""


def tasks(args: TasksArgs) -> None:
    from bimanualshift.sim.task import TASKS
    from bimanualshift.sim.task_registry import task_names

    for name in task_names():
        cls = TASKS[name]
        print(f"{name:24s} {'bimanual' if cls.bimanual else 'single-arm':10s} {(cls.__doc__ or '').strip()}")


@dataclass
class CollectArgs:
    task: list[str]  # task name(s), or all / bimanual / unimanual
    episodes: int  # number of seeds to try per task
    out: str  # output directory (one sub-folder per task)
    split: Literal["train", "validation", "test"] = "train"  # seed range to draw from; the three never overlap
    start: int = 0  # first seed offset within the split
    workers: int = 1  # parallel worker processes
    image_size: int = 0  # camera resolution (0: the robot's own: 128 on the Panda, 256 on the UR5e twin)
    executor: Literal["local", "ray"] = "local"  # local worker processes, or Ray tasks on the cluster RAY_ADDRESS names


def collect(args: CollectArgs) -> None:
    from bimanualshift.data.collect import collect as collect_demos
    from bimanualshift.data.seeds import split_seeds

    names = resolve_tasks(args.task)
    if args.episodes < 1:
        raise ValueError("--episodes must be at least 1")
    stats = collect_demos(names, split_seeds(args.split, args.episodes, args.start), args.out, workers=args.workers,
                          image_size=args.image_size or None, executor=args.executor)
    for task, s in stats.items():
        print(f"{task}: {s['succeeded']}/{s['attempted']} expert episodes succeeded and were saved "
              f"({s['skipped']} already present) under {Path(args.out) / task}")


@dataclass
class ExpertsArgs:
    task: list[str] = field(default_factory=lambda: ["all"])  # task name(s), or all / bimanual / unimanual
    episodes: int = 100  # seeds per task
    workers: int = 1  # parallel worker processes
    out: str = ""  # write a result JSON here (e.g. results/experts.json)
    executor: Literal["local", "ray"] = "local"  # local worker processes, or Ray tasks on the cluster RAY_ADDRESS names
    # perturbation presets to run under, one row per task and preset (e.g. lighting swap_sides; `none`: as trained)
    perturb: list[str] = field(default_factory=lambda: ["none"])


def experts(args: ExpertsArgs) -> None:
    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.experts import expert_rows
    from bimanualshift.evaluation.report import write_result
    from bimanualshift.sim.expert_check import check_experts
    from bimanualshift.sim.perturbations import preset

    names = resolve_tasks(args.task)
    started = time.time()
    seeds = split_seeds("test", args.episodes)
    for name in args.perturb:
        preset(name)  # an unknown preset fails before any episode runs
    rows = []
    for name in args.perturb:
        episodes = check_experts(names, seeds, workers=args.workers, executor=args.executor, perturbation=name)
        rows += [{**row, "perturbation": name} if args.perturb != ["none"] else row
                 for row in expert_rows(names, episodes)]
    for row in rows:
        label = f"{row['task']} ({row['perturbation']})" if "perturbation" in row else row["task"]
        print(f"{label:36s} {100 * row['success']:5.1f} %  "
              f"({round(row['success'] * row['episodes'])}/{row['episodes']})  "
              f"{row['mean_wall_time_s']:.1f} s/episode  {row['mean_keyframes']:.1f} keyframes")
    if args.out:
        write_result(args.out, command_line(), {"test": seeds}, started, rows,
                     notes="scripted experts, no rendering; wall time per episode with "
                           f"{args.workers} worker process(es) on this machine")
        print(f"wrote {args.out}")


@dataclass
class SceneArgs:
    """Which first scenes to show: the tasks, the seed and a perturbation preset."""

    task: list[str] = field(default_factory=lambda: ["all"])  # task name(s), or all / bimanual / unimanual
    seed: int = 0
    perturb: str = "none"  # a perturbation preset, e.g. lighting or swap_sides


@dataclass
class SnapshotArgs(SceneArgs):
    out: str = "docs/img/tasks"  # output folder
    image_size: int = 256
    cameras: list[str] = field(default_factory=lambda: ["front", "overhead"])


def _first_scenes(tasks: Iterable[str], image_size: int, perturb: str, seed: int) -> Iterator[tuple[str, Any]]:
    """(task, its env reset to ``seed`` without rendering), one task at a time; each env is closed after use."""
    from bimanualshift.sim.env import ManipulationEnv
    from bimanualshift.sim.perturbations import preset

    for task in tasks:
        env = ManipulationEnv(task, image_size=image_size, perturbations=preset(perturb))
        env.reset(seed=seed, options={"render": False})
        yield task, env
        env.close()


def snapshot(args: SnapshotArgs) -> None:
    import imageio.v3 as iio
    import numpy as np

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for task, env in _first_scenes(resolve_tasks(args.task), args.image_size, args.perturb, args.seed):
        views = env.cameras.render(env.data, depth_and_segmentation=False)
        shown = [c for c in args.cameras if c in views] or list(views)[:1]  # the UR5e twin has one camera
        image = np.concatenate([views[c].rgb for c in shown], axis=1)
        path = out / f"{task}{'' if args.perturb == 'none' else '_' + args.perturb}.png"
        iio.imwrite(path, image)
        print(f"{path}: {env.task.instruction()!r}")


@dataclass
class VideoArgs(SceneArgs):
    out: str = "docs/videos"  # output folder
    image_size: int = 192
    cameras: list[str] = field(default_factory=lambda: ["front", "over_shoulder_left"])
    every: int = 3  # control steps (50 ms each) per frame
    fps: int = 13  # frames per second of the video


def video(args: VideoArgs) -> None:
    from tqdm import tqdm

    from bimanualshift.evaluation.media import write_video

    out = Path(args.out)
    tasks = tqdm(resolve_tasks(args.task), desc="video", unit="task")
    for task, env in _first_scenes(tasks, args.image_size, args.perturb, args.seed):
        env.start_video(tuple(args.cameras), every=args.every)
        for keyframe in env.expert_keyframes():
            env.step(env.action_from_keyframe(keyframe), render=False)
        success = env.success()
        path = write_video(out / f"{task}.mp4", env.video_frames(), fps=args.fps)
        tqdm.write(f"{path}: {env.task.instruction()!r}, expert {'succeeded' if success else 'FAILED'}")
