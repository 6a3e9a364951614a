"""The `bimanualshift` command line: one command, one sub-command per stage."""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from dataclasses import fields
from pathlib import Path

DESCRIPTION = """BimanualShift: reuse a frozen single-arm policy for both arms of a bimanual robot.

Typical flow:
  bimanualshift collect  --task push_button --episodes 80 --out data/unimanual
  bimanualshift pretrain --data data/unimanual --out runs/prior
  bimanualshift collect  --task push_two_buttons --episodes 20 --out data/bimanual
  bimanualshift train    --task push_two_buttons --prior runs/prior/best --data data/bimanual
  bimanualshift eval     --checkpoint runs/bimanualshift/best --episodes 20
or everything at once:   bimanualshift demo
"""


def _add_config_overrides(parser: argparse.ArgumentParser, config_cls: type, skip: tuple[str, ...] = ()) -> None:
    """Expose every field of a config dataclass as --field-name, typed from its default, with the field's
    comment in the config's source as its help."""
    from bimanualshift.utils.field_help import field_help

    comments = field_help(config_cls)
    for f in fields(config_cls):
        if f.name in skip:
            continue
        flag = "--" + f.name.replace("_", "-")
        default = f.default if not callable(f.default_factory) else f.default_factory()  # type: ignore[misc]
        about = comments.get(f.name, "").replace("%", "%%")  # argparse formats help with %
        about = f"{about} " if about else ""
        if isinstance(default, bool):
            parser.add_argument(flag, type=lambda s: s.lower() in ("1", "true", "yes"), default=None,
                                metavar="true|false", help=f"{about}(default: {default})")
        elif isinstance(default, list):
            parser.add_argument(flag, nargs="+", default=None,
                                help=f"{about}(default: {' '.join(map(str, default))})")
        elif isinstance(default, dict):
            parser.add_argument(flag, type=json.loads, default=None,
                                help=f"{about}JSON object (default: {default})")
        else:
            parser.add_argument(flag, type=type(default), default=None, help=f"{about}(default: {default})")


def _add_config_command(sub: argparse._SubParsersAction, name: str, help_text: str, config_cls: type,
                        func: Callable[[argparse.Namespace], None]) -> None:
    """A sub-command configured by a dataclass: --config FILE.json, then one flag per field on top."""
    p = sub.add_parser(name, help=help_text)
    p.add_argument("--config", help=f"JSON file with {config_cls.__name__} fields, e.g. a run's saved config "
                                    "(flags override it)")
    _add_config_overrides(p, config_cls)
    p.set_defaults(func=func)


def _config_from_args(config_cls: type, args: argparse.Namespace):  # noqa: ANN202
    values = {}
    if getattr(args, "config", None):
        path = Path(args.config)
        if not path.is_file():
            sys.exit(f"error: config file {path} does not exist")
        raw = json.loads(path.read_text())
        names = {f.name for f in fields(config_cls)}
        unknown = sorted(set(raw) - names)
        if unknown:
            sys.exit(f"error: {path} has unknown keys {unknown}; known keys: {sorted(names)}")
        values.update(raw)
    for f in fields(config_cls):
        v = getattr(args, f.name, None)
        if v is not None:
            values[f.name] = v
    return config_cls(**values)


def _resolve_tasks(requested: list[str]) -> list[str]:
    """Task names from --task: registered names, 'all', 'bimanual' or 'unimanual'; exits with the list of
    choices otherwise."""
    from bimanualshift.sim.task import resolve_task_names

    try:
        return resolve_task_names(requested)
    except ValueError as err:
        sys.exit(f"error: {err}")


def cmd_tasks(args: argparse.Namespace) -> None:
    from bimanualshift.sim.task import TASKS, task_names

    for name in task_names():
        cls = TASKS[name]
        print(f"{name:24s} {'bimanual' if cls.bimanual else 'single-arm':10s} {(cls.__doc__ or '').strip()}")


def cmd_collect(args: argparse.Namespace) -> None:
    from bimanualshift.data.collect import collect
    from bimanualshift.data.seeds import split_seeds

    tasks = _resolve_tasks(args.task)
    if args.episodes < 1:
        sys.exit("error: --episodes must be at least 1")
    stats = collect(tasks, split_seeds(args.split, args.episodes, args.start), args.out, workers=args.workers,
                    image_size=args.image_size, executor=args.executor)
    for task, s in stats.items():
        print(f"{task}: {s['succeeded']}/{s['attempted']} expert episodes succeeded and were saved "
              f"({s['skipped']} already present) under {Path(args.out) / task}")


def cmd_experts(args: argparse.Namespace) -> None:
    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.report import write_result
    from bimanualshift.evaluation.stats import wilson_interval
    from bimanualshift.sim.expert_check import check_experts
    from bimanualshift.sim.task import TASKS

    tasks = _resolve_tasks(args.task)
    started = time.time()
    seeds = split_seeds("test", args.episodes)
    episodes = check_experts(tasks, seeds, workers=args.workers, executor=args.executor)
    rows = []
    for task in tasks:
        mine = [e for e in episodes if e.task == task]
        k = sum(e.success for e in mine)
        lo, hi = wilson_interval(k, len(mine))
        rows.append({"task": task, "bimanual": TASKS[task].bimanual, "success": round(k / len(mine), 4),
                     "episodes": len(mine), "ci95": [round(lo, 4), round(hi, 4)],
                     "mean_wall_time_s": round(float(sum(e.wall_time_s for e in mine) / len(mine)), 2),
                     "mean_keyframes": round(float(sum(e.keyframes for e in mine) / len(mine)), 2),
                     "failed_seeds": [e.seed for e in mine if not e.success]})
        print(f"{task:24s} {100 * k / len(mine):5.1f} %  ({k}/{len(mine)})  "
              f"{rows[-1]['mean_wall_time_s']:.1f} s/episode  {rows[-1]['mean_keyframes']:.1f} keyframes")
    if args.out:
        write_result(args.out, "bimanualshift " + " ".join(sys.argv[1:]), {"test": seeds}, started, rows,
                     notes="scripted experts, no rendering; wall time per episode with "
                           f"{args.workers} worker process(es) on this machine")
        print(f"wrote {args.out}")


def cmd_snapshot(args: argparse.Namespace) -> None:
    import imageio.v3 as iio
    import numpy as np

    from bimanualshift.sim.env import ManipulationEnv
    from bimanualshift.sim.perturbations import preset
    tasks = _resolve_tasks(args.task)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for task in tasks:
        env = ManipulationEnv(task, image_size=args.image_size, perturbations=preset(args.perturb))
        env.reset(seed=args.seed, options={"render": False})
        views = env.cameras.render(env.data, depth_and_segmentation=False)
        image = np.concatenate([views[c].rgb for c in args.cameras], axis=1)
        path = out / f"{task}{'' if args.perturb == 'none' else '_' + args.perturb}.png"
        iio.imwrite(path, image)
        print(f"{path}: {env.task.instruction()!r}")
        env.close()


def cmd_video(args: argparse.Namespace) -> None:
    from tqdm import tqdm

    from bimanualshift.evaluation.media import write_video
    from bimanualshift.sim.env import ManipulationEnv
    from bimanualshift.sim.perturbations import preset
    out = Path(args.out)
    for task in tqdm(_resolve_tasks(args.task), desc="video", unit="task"):
        env = ManipulationEnv(task, image_size=args.image_size, perturbations=preset(args.perturb))
        env.reset(seed=args.seed, options={"render": False})
        env.start_video(tuple(args.cameras), every=args.every)
        for keyframe in env.expert_keyframes():
            env.step(env.action_from_keyframe(keyframe), render=False)
        success = env.success()
        path = write_video(out / f"{task}.mp4", env.video_frames(), fps=args.fps)
        tqdm.write(f"{path}: {env.task.instruction()!r}, expert {'succeeded' if success else 'FAILED'}")
        env.close()


def cmd_viz_projection(args: argparse.Namespace) -> None:
    from bimanualshift.data.frames import KeyframeObservation, scene_of_env
    from bimanualshift.perception.projection import ArmProjection
    from bimanualshift.perception.segmenters import make_segmenter
    from bimanualshift.sim.env import ManipulationEnv
    from bimanualshift.viz.projection_figure import projection_figure

    out = Path(args.out)
    for task in _resolve_tasks(args.task):
        env = ManipulationEnv(task, image_size=args.image_size)
        if not env.task.bimanual:
            sys.exit(f"error: {task} is a single-arm task; the projection separates two arms")
        obs, _ = env.reset(seed=args.seed)
        keyframes = env.expert_keyframes()
        index = len(keyframes) // 2 if args.keyframe is None else min(args.keyframe, len(keyframes))
        for keyframe in keyframes[:index]:
            obs, *_ = env.step(env.action_from_keyframe(keyframe))
        frame = KeyframeObservation.from_env(obs, scene_of_env(env))
        projection = ArmProjection(make_segmenter(args.segmenter, seed=args.seed))
        path = projection_figure(frame, projection, out / f"{task}.png",
                                 title=f"{task}, seed {args.seed}, keyframe {index}: {env.task.instruction()!r}")
        print(f"{path} ({args.segmenter} segmenter)")
        env.close()


def _quality_job(job: tuple[str, list[int], list[str], int]) -> list[dict]:
    from bimanualshift.perception.quality import projection_quality

    return projection_quality(*job, progress=False)


def cmd_projection_quality(args: argparse.Namespace) -> None:
    import time

    from rich.console import Console
    from rich.table import Table

    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.report import write_result
    from bimanualshift.utils.workers import run_jobs

    tasks = _resolve_tasks(args.task)
    seeds = split_seeds("test", args.episodes)
    jobs = [(task, seeds, args.segmenters, args.image_size) for task in tasks]
    started = time.time()
    results = run_jobs(_quality_job, jobs, args.workers, desc="projection quality", chunksize=1)
    rows = [row for task in tasks for result in results if result and result[0]["task"] == task for row in result]
    table = Table(title="arm-conditioned projection: voxels kept (own arm + goal) / removed (other arm)")
    for col in ("task", "segmenter", "arm", "kept", "removed", "keyframes"):
        table.add_column(col)
    for r in rows:
        table.add_row(r["task"], r["segmenter"], r["arm"], f"{r['kept']:.3f}", f"{r['removed']:.3f}",
                      str(r["keyframes"]))
    Console().print(table)
    if args.out:
        write_result(args.out, "bimanualshift " + " ".join(sys.argv[1:]), {"test": seeds}, started, rows,
                     notes="voxels are 2 cm cells of the table-top workspace; every keyframe of the scripted expert's "
                           "episodes, including the first observation; segmenter noise seeded with 0")
        print(f"wrote {args.out}")


def cmd_prior_report(args: argparse.Namespace) -> None:
    from rich.console import Console
    from rich.table import Table

    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.priors import evaluate_priors, prior_rows
    from bimanualshift.evaluation.report import write_result

    tasks = _resolve_tasks(args.task)
    started = time.time()
    seeds = split_seeds("test", args.episodes)
    log = args.log or (str(Path(args.out).with_suffix(".episodes.jsonl")) if args.out else None)
    deadline = started + 60 * args.minutes if args.minutes else None
    episodes = evaluate_priors(args.prior, tasks, seeds, workers=args.workers, log=log, deadline=deadline,
                               executor=args.executor)
    rows = prior_rows(args.prior, episodes, tasks, seeds[0])
    counts = sorted({t["episodes"] for r in rows for t in r["tasks"].values()})
    interim = counts != [args.episodes]
    table = Table(title=f"single-arm priors ({args.episodes} test seeds per task)")
    table.add_column("task")
    for row in rows:
        table.add_column(row["prior"], justify="right")
    for task in tasks:
        table.add_row(task, *[f"{100 * r['tasks'][task]['success']:.0f} % "
                              f"[{100 * r['tasks'][task]['ci95'][0]:.0f}, {100 * r['tasks'][task]['ci95'][1]:.0f}]"
                              for r in rows])
    table.add_row("mean", *[f"{100 * r['mean_success']:.1f} %" for r in rows])
    table.add_row("parameters", *[f"{r['parameters']:,}" for r in rows])
    table.add_row("ms per arm", *[f"{r['inference_ms_per_arm']}" for r in rows])
    Console().print(table)
    if args.out:
        notes = ("each prior drives the single arm alone (no projection, no residual); a rollout stops at twice the "
                 "expert's keyframe count on the same seed; inference is the median of 20 predict calls for one arm "
                 "with 2 torch threads")
        if interim:
            notes = (f"INTERIM: stopped by --minutes with {counts[0]}-{counts[-1]} of {args.episodes} test seeds per "
                     f"task done (per-episode log {log}); the same command without --minutes finishes it. " + notes)
        write_result(args.out, "bimanualshift " + " ".join(sys.argv[1:]), {"test": seeds}, started, rows,
                     notes=notes, episode_log=log)
        print(f"wrote {args.out}")


def cmd_pretrain(args: argparse.Namespace) -> None:
    from bimanualshift.training.pretrain import PretrainConfig, pretrain

    best = pretrain(_config_from_args(PretrainConfig, args))
    print(f"best prior checkpoint: {best}")


def cmd_train(args: argparse.Namespace) -> None:
    from bimanualshift.training.residual import TrainConfig, train_residual

    best = train_residual(_config_from_args(TrainConfig, args))
    print(f"best BimanualShift checkpoint: {best}")


def cmd_refine(args: argparse.Namespace) -> None:
    from bimanualshift.training.refine import RefineConfig, refine

    best = refine(_config_from_args(RefineConfig, args))
    print(f"refined BimanualShift checkpoint: {best}")


def cmd_bench(args: argparse.Namespace) -> None:
    from bimanualshift.evaluation.bench import BenchConfig, run_bench

    summary = run_bench(_config_from_args(BenchConfig, args))
    print(f"wrote {summary} (table.md, success.png, episodes.jsonl, videos/ beside it)")


def cmd_study(args: argparse.Namespace) -> None:
    from bimanualshift.evaluation.bench import BenchConfig
    from bimanualshift.evaluation.studies import run_study

    overrides = {f.name: getattr(args, f.name) for f in fields(BenchConfig) if getattr(args, f.name, None) is not None}
    print(f"wrote {run_study(args.name, overrides, args.results)}")


def cmd_ship_prior(args: argparse.Namespace) -> None:
    from bimanualshift.priors.shipping import ship_prior

    print(f"shipped {ship_prior(args.source, args.name)}")


def cmd_eval(args: argparse.Namespace) -> None:
    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.encoders.text import default_text_encoder
    from bimanualshift.evaluation.report import print_success_table, success_rows, write_result
    from bimanualshift.evaluation.rollout import evaluate
    from bimanualshift.methods.bimanualshift import load_bimanualshift
    from bimanualshift.methods.frozen_prior import FrozenPriorPerArm
    from bimanualshift.sim.env import ManipulationEnv

    started = time.time()
    text_encoder = default_text_encoder()
    if args.method == "bimanualshift":
        if not args.checkpoint:
            sys.exit("error: --checkpoint DIR (from `bimanualshift train`) is required for --method bimanualshift")
        policy = load_bimanualshift(args.checkpoint, text_encoder)
    else:
        if not args.prior:
            sys.exit(f"error: --prior DIR is required for --method {args.method}")
        policy = FrozenPriorPerArm.from_pretrained(args.prior, text_encoder, name=args.method,
                                                   use_projection=args.method == "no_residual")
    seeds = split_seeds(args.split, args.episodes)
    records = []
    for task in args.task:
        env = ManipulationEnv(task)
        records += evaluate(env, policy, seeds, args.max_keyframes or env.task.max_keyframes)
        env.close()
    rows = success_rows(records)
    print_success_table(rows, f"{' '.join(args.task)} ({args.split} seeds)")
    if args.out:
        write_result(args.out, "bimanualshift " + " ".join(sys.argv[1:]), {args.split: seeds}, started, rows)
        print(f"wrote {args.out}")


def cmd_demo(args: argparse.Namespace) -> None:
    from bimanualshift.demo import DemoConfig, run_demo

    run_demo(_config_from_args(DemoConfig, args))


def cmd_plot(args: argparse.Namespace) -> None:
    from bimanualshift.evaluation.bench import redraw_plots

    for folder in args.folders:
        print(f"drew {', '.join(str(p) for p in redraw_plots(folder))}")


def cmd_report(args: argparse.Namespace) -> None:
    from bimanualshift.evaluation.markdown import render_readme

    if args.index:
        from bimanualshift.evaluation.markdown import render_index

        print(f"wrote {render_index(args.results)}")
    for readme in args.readme:
        names = render_readme(readme, args.results)
        print(f"{readme}: regenerated {', '.join(names) if names else 'no results blocks'}")


def _add_executor(p: argparse.ArgumentParser) -> None:
    from bimanualshift.utils.workers import EXECUTORS

    p.add_argument("--executor", default="local", choices=EXECUTORS,
                   help="local worker processes (default), or Ray tasks on the cluster RAY_ADDRESS names")


def build_parser() -> argparse.ArgumentParser:
    from bimanualshift.demo import DemoConfig
    from bimanualshift.evaluation.bench import BenchConfig
    from bimanualshift.training.pretrain import PretrainConfig
    from bimanualshift.training.refine import RefineConfig
    from bimanualshift.training.residual import TrainConfig

    parser = argparse.ArgumentParser(prog="bimanualshift", description=DESCRIPTION,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("tasks", help="list the registered tasks")
    p.set_defaults(func=cmd_tasks)

    p = sub.add_parser("collect", help="record scripted-expert demonstrations to HDF5 (successes only)")
    p.add_argument("--task", nargs="+", required=True, help="task name(s), or 'all'")
    p.add_argument("--episodes", type=int, required=True, help="number of seeds to try per task")
    p.add_argument("--out", required=True, help="output directory (one sub-folder per task)")
    p.add_argument("--split", default="train", choices=["train", "validation", "test"],
                   help="seed range to draw from; the three ranges never overlap (default: train)")
    p.add_argument("--start", type=int, default=0, help="first seed offset within the split (default: 0)")
    p.add_argument("--workers", type=int, default=1, help="parallel worker processes (default: 1)")
    p.add_argument("--image-size", type=int, default=128, help="camera resolution (default: 128)")
    _add_executor(p)
    p.set_defaults(func=cmd_collect)

    p = sub.add_parser("experts", help="measure the scripted experts' success rate on test seeds (no rendering)")
    p.add_argument("--task", nargs="+", default=["all"], help="task name(s), or all (default) / bimanual / unimanual")
    p.add_argument("--episodes", type=int, default=100, help="seeds per task (default: 100)")
    p.add_argument("--workers", type=int, default=1, help="parallel worker processes (default: 1)")
    p.add_argument("--out", help="write a result JSON here (e.g. results/experts.json)")
    _add_executor(p)
    p.set_defaults(func=cmd_experts)

    p = sub.add_parser("snapshot", help="render a picture of each task's first scene (for the docs)")
    p.add_argument("--task", nargs="+", default=["all"], help="task name(s), or all (default) / bimanual / unimanual")
    p.add_argument("--out", default="docs/img/tasks", help="output folder (default: docs/img/tasks)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--image-size", type=int, default=256)
    p.add_argument("--cameras", nargs="+", default=["front", "overhead"])
    p.add_argument("--perturb", default="none", help="a perturbation preset, e.g. lighting or swap_sides")
    p.set_defaults(func=cmd_snapshot)

    p = sub.add_parser("viz", help="figures: `viz projection` draws the arm-conditioned projection (paper Fig. 3)")
    viz = p.add_subparsers(dest="figure", required=True)
    p = viz.add_parser("projection", help="the voxel scene and each arm's projected view, as a PNG per task")
    p.add_argument("--task", nargs="+", default=["bimanual"], help="bimanual task name(s), or bimanual (default)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--keyframe", type=int, help="show the scene after this many expert keyframes (default: half)")
    p.add_argument("--segmenter", default="simulator", help="simulator (default), degraded-mild, degraded-strong")
    p.add_argument("--image-size", type=int, default=128)
    p.add_argument("--out", default="docs/img/projection", help="output folder (default: docs/img/projection)")
    p.set_defaults(func=cmd_viz_projection)

    p = sub.add_parser("projection-quality", help="measure how well the projection keeps each arm + goal and "
                                                  "removes the other arm (voxels, simulator ground truth)")
    p.add_argument("--task", nargs="+", default=["bimanual"], help="bimanual task name(s), or bimanual (default)")
    p.add_argument("--episodes", type=int, default=50, help="test seeds per task (default: 50)")
    p.add_argument("--segmenters", nargs="+", default=["simulator", "degraded-mild", "degraded-strong"])
    p.add_argument("--image-size", type=int, default=128)
    p.add_argument("--workers", type=int, default=1, help="parallel worker processes, one task each (default: 1)")
    p.add_argument("--out", help="write a result JSON here (e.g. results/projection_quality.json)")
    p.set_defaults(func=cmd_projection_quality)

    p = sub.add_parser("video", help="record the scripted expert solving each task to MP4 (for the docs)")
    p.add_argument("--task", nargs="+", default=["all"], help="task name(s), or all (default) / bimanual / unimanual")
    p.add_argument("--out", default="docs/videos", help="output folder (default: docs/videos)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--image-size", type=int, default=192)
    p.add_argument("--cameras", nargs="+", default=["front", "over_shoulder_left"])
    p.add_argument("--every", type=int, default=3, help="control steps (50 ms each) per frame (default: 3)")
    p.add_argument("--fps", type=int, default=13, help="frames per second of the video (default: 13)")
    p.add_argument("--perturb", default="none", help="a perturbation preset, e.g. lighting or swap_sides")
    p.set_defaults(func=cmd_video)

    p = sub.add_parser("prior-report", help="single-arm success, size and speed of frozen priors (results/priors.json)")
    p.add_argument("--prior", nargs="+", required=True, help="prior checkpoint folder(s) or shipped name(s)")
    p.add_argument("--task", nargs="+", default=["unimanual"], help="single-arm task(s) (default: unimanual)")
    p.add_argument("--episodes", type=int, default=50, help="test seeds per task (default: 50)")
    p.add_argument("--workers", type=int, default=1, help="parallel worker processes (default: 1)")
    p.add_argument("--out", help="write a result JSON here (e.g. results/priors.json)")
    p.add_argument("--log", help="per-episode log a stopped report resumes from (default: OUT with .episodes.jsonl)")
    p.add_argument("--minutes", type=float, default=0.0,
                   help="stop after this long and write an interim result (resume later with the same command)")
    _add_executor(p)
    p.set_defaults(func=cmd_prior_report)

    _add_config_command(sub, "pretrain", "pretrain a single-arm prior on single-arm demos only", PretrainConfig,
                        cmd_pretrain)
    _add_config_command(sub, "train", "train the residual branch on bimanual demos (prior frozen)", TrainConfig,
                        cmd_train)
    _add_config_command(sub, "refine", "retrieval-conditioned refinement: roll out on training scenes, correct "
                                       "failures with the expert, fine-tune the residual, grow the memory bank",
                        RefineConfig, cmd_refine)

    _add_config_command(sub, "bench", "methods x bimanual tasks on fixed seeds: train, evaluate in parallel, "
                                      "table, plot, videos (resumable)", BenchConfig, cmd_bench)

    p = sub.add_parser("ship-prior", help="copy a pretrained prior (a run's best/) into checkpoints/NAME/ with its "
                                          "model card (<= 25 MB)")
    p.add_argument("source", help="the best/ folder of a `pretrain` run")
    p.add_argument("name", help="the name it loads by, e.g. peract_suite")
    p.set_defaults(func=cmd_ship_prior)

    from bimanualshift.evaluation.studies import STUDIES

    p = sub.add_parser("study", help=f"one of the paper's studies ({', '.join(STUDIES)}) as benchmark runs, "
                                     "combined into results/<study>/")
    p.add_argument("name", choices=STUDIES)
    p.add_argument("--results", default="results", help="where results/<study>/ goes (default: results)")
    _add_config_overrides(p, BenchConfig, skip=("out", "runs"))
    p.set_defaults(func=cmd_study)

    p = sub.add_parser("plot", help="redraw a bench or study folder's plots (success.png, stages.png) from its "
                                    "summary.json, without running anything")
    p.add_argument("folders", nargs="+", help="result folders holding a summary.json, e.g. results/long_horizon")
    p.set_defaults(func=cmd_plot)

    p = sub.add_parser("eval", help="evaluate a method on held-out seeds")
    p.add_argument("--method", default="bimanualshift",
                   choices=["bimanualshift", "frozen_prior_per_arm", "no_residual", "prior"],
                   help="bimanualshift (needs --checkpoint); frozen_prior_per_arm = the frozen prior driving each "
                        "arm on the global scene; no_residual = the same through the projection (ablation); "
                        "prior = the frozen prior, named for single-arm tasks (the last three need --prior)")
    p.add_argument("--checkpoint", help="BimanualShift checkpoint directory (from `train`)")
    p.add_argument("--prior", help="prior checkpoint directory (for the methods other than bimanualshift)")
    p.add_argument("--task", nargs="+", default=["push_two_buttons"], help="one or more task names")
    p.add_argument("--episodes", type=int, default=20, help="episodes per task")
    p.add_argument("--split", default="test", choices=["validation", "test"])
    p.add_argument("--max-keyframes", type=int, default=None, help="episode length limit (default: the task's)")
    p.add_argument("--out", help="write a result JSON here")
    p.set_defaults(func=cmd_eval)

    _add_config_command(sub, "demo", "collect, (pre)train, train the residual, evaluate: the whole method",
                        DemoConfig, cmd_demo)

    p = sub.add_parser("report", help="regenerate the README tables from the result files")
    p.add_argument("--readme", nargs="+", default=["README.md"], help="files with results blocks")
    p.add_argument("--results", default="results", help="results directory (default: results)")
    p.add_argument("--index", action="store_true", help="also write results/README.md: every result file's table")
    p.set_defaults(func=cmd_report)
    return parser


def main(argv: list[str] | None = None) -> None:
    args = build_parser().parse_args(argv)
    args.func(args)


if __name__ == "__main__":
    main()
