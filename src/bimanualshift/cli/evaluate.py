"""Commands that measure: evaluate a method, run the benchmark or a study, the prior report, the projection's
quality; and the ones that redraw plots and README tables from result files."""

from __future__ import annotations

import time
from dataclasses import dataclass, field, fields, make_dataclass
from pathlib import Path
from typing import Annotated, Literal

import tyro

from bimanualshift.cli.common import command_line, resolve_tasks
from bimanualshift.evaluation.bench import BenchConfig
from bimanualshift.evaluation.studies import STUDIES


@dataclass
class EvalArgs:
    # bimanualshift (needs --checkpoint); frozen_prior_per_arm = the frozen prior driving each arm on the global
    # scene; no_residual = the same through the projection (ablation); prior = the frozen prior, named for
    # single-arm tasks (the last three need --prior)
    method: Literal["bimanualshift", "frozen_prior_per_arm", "no_residual", "prior"] = "bimanualshift"
    checkpoint: str = ""  # BimanualShift checkpoint directory (from `train`)
    prior: str = ""  # prior checkpoint directory or shipped name (for the methods other than bimanualshift)
    task: list[str] = field(default_factory=lambda: ["push_two_buttons"])  # one or more task names
    episodes: int = 20  # episodes per task
    split: Literal["validation", "test"] = "test"
    # an episode stops at twice the expert's keyframe count on the same seed, and at most after this many (0: no cap)
    max_keyframes: int = 0
    out: str = ""  # write a result JSON here
    # write every episode to this rerun recording (.rrd: cameras, each arm's projection, proposals and actions;
    # open it with `rerun FILE.rrd`)
    rrd: str = ""


def evaluate(args: EvalArgs) -> None:
    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.encoders.text import default_text_encoder
    from bimanualshift.evaluation.report import success_rows, write_result
    from bimanualshift.evaluation.tables import print_success_table
    from bimanualshift.methods.bimanualshift import load_bimanualshift
    from bimanualshift.methods.frozen_prior import FrozenPriorPerArm
    from bimanualshift.rollout.loop import evaluate as evaluate_policy
    from bimanualshift.sim.env import ManipulationEnv

    started = time.time()
    names = resolve_tasks(args.task)
    if args.method == "bimanualshift" and not args.checkpoint:
        raise ValueError("--checkpoint DIR (from `bimanualshift train`) is required for --method bimanualshift")
    if args.method != "bimanualshift" and not args.prior:
        raise ValueError(f"--prior DIR is required for --method {args.method}")
    text_encoder = default_text_encoder()
    if args.method == "bimanualshift":
        policy = load_bimanualshift(args.checkpoint, text_encoder)
    else:
        policy = FrozenPriorPerArm.from_pretrained(args.prior, text_encoder, name=args.method,
                                                   use_projection=args.method == "no_residual")
    seeds = split_seeds(args.split, args.episodes)
    recorder = None
    if args.rrd:
        from bimanualshift.evaluation.viewer import EpisodeRecorder

        recorder = EpisodeRecorder(args.rrd)
    records = []
    for task in names:
        env = ManipulationEnv(task)
        records += evaluate_policy(env, policy, seeds, args.max_keyframes, observer=recorder)
        env.close()
    if recorder is not None:
        recorder.close()
        print(f"wrote {args.rrd} (open it with `rerun {args.rrd}`)")
    rows = success_rows(records)
    print_success_table(rows, f"{' '.join(names)} ({args.split} seeds)")
    if args.out:
        # per seed its outcome and the digest of its actions: the same (checkpoint, task, seed) through `bench`,
        # `study` or `serve` + `deploy` gives the same digest
        episodes = [{"task": r.task, "method": r.method, "seed": r.seed, "success": r.success,
                     "keyframes": r.keyframes, "stages_done": r.stages_done, "actions_sha256": r.actions_sha256}
                    for r in records]
        write_result(args.out, command_line(), {args.split: seeds}, started, rows, episodes=episodes)
        print(f"wrote {args.out}")


def bench(cfg: BenchConfig) -> None:
    from bimanualshift.evaluation.bench import run_bench

    summary = run_bench(cfg)
    print(f"wrote {summary} (table.md, success.png, episodes.jsonl, videos/ beside it)")


# `study NAME`: every BenchConfig field but the folders (and the cells a run shares with another study's), each
# optional: only the flags given override the study's own settings (a study's runs differ in demos, tasks and folders).
StudyOverrides = make_dataclass("StudyOverrides", [
    (f.name, f.type + " | None", field(default=None)) for f in fields(BenchConfig)
    if f.name not in ("out", "runs", "share_from")])
StudyOverrides.__doc__ = "Flags that override every run of the study."
StudyOverrides.__module__ = __name__


@dataclass
class StudyArgs:
    # (the help is given explicitly: a trailing comment here would carry the type checker's marker into --help)
    name: Annotated[Literal[STUDIES], tyro.conf.Positional,  # type: ignore[valid-type]
                    tyro.conf.arg(help="the study to run")]
    results: str = "results"  # where results/<study>/ goes
    # tabulate only the methods whose every episode is recorded (in every run of their group; a run with none,
    # e.g. a backbone not yet benchmarked, is left out): nothing trains or rolls out, so a half-finished study
    # gives its finished rows
    recorded_only: bool = False
    # print how much of the study is recorded (per run folder, task and method: rollouts recorded / planned) and
    # stop: nothing trains, rolls out or is written
    status: bool = False
    overrides: Annotated[StudyOverrides, tyro.conf.arg(  # type: ignore[valid-type]
        help="bench flags that override every run of the study; unset, each run keeps the study's own setting "
             "(their meanings: `bimanualshift bench --help`)")] = field(default_factory=StudyOverrides)


def study(args: StudyArgs) -> None:
    from bimanualshift.evaluation.studies import run_study

    overrides = {f.name: getattr(args.overrides, f.name) for f in fields(args.overrides)
                 if getattr(args.overrides, f.name) is not None}
    if args.status:
        from bimanualshift.evaluation.studies import study_status
        from bimanualshift.evaluation.tables import print_study_status

        print_study_status(study_status(args.name, overrides, args.results), args.name)
        return
    print(f"wrote {run_study(args.name, overrides, args.results, args.recorded_only)}")


@dataclass
class ProjectionQualityArgs:
    task: list[str] = field(default_factory=lambda: ["bimanual"])  # bimanual task name(s), or bimanual
    episodes: int = 50  # test seeds per task
    segmenters: list[str] = field(default_factory=lambda: ["simulator", "degraded-mild", "degraded-strong"])
    image_size: int = 0  # 0: the task robot's own (128 on the Panda, 256 on the UR5e twin)
    workers: int = 1  # parallel worker processes, one task each
    out: str = ""  # write a result JSON here (e.g. results/projection_quality.json)


def projection_quality(args: ProjectionQualityArgs) -> None:
    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.report import write_result
    from bimanualshift.evaluation.tables import print_projection_quality
    from bimanualshift.perception.quality import projection_quality_job
    from bimanualshift.utils.workers import run_jobs

    names = resolve_tasks(args.task)
    seeds = split_seeds("test", args.episodes)
    jobs = [(task, seeds, args.segmenters, args.image_size) for task in names]
    started = time.time()
    results = run_jobs(projection_quality_job, jobs, args.workers, desc="projection quality", chunksize=1)
    rows = [row for task in names for result in results if result and result[0]["task"] == task for row in result]
    print_projection_quality(rows)
    if args.out:
        write_result(args.out, command_line(), {"test": seeds}, started, rows,
                     notes="voxels are 2 cm cells of the table-top workspace; every keyframe of the scripted expert's "
                           "episodes, including the first observation; segmenter noise seeded with 0")
        print(f"wrote {args.out}")


@dataclass
class PriorReportArgs:
    prior: list[str]  # prior checkpoint folder(s) or shipped name(s)
    task: list[str] = field(default_factory=lambda: ["unimanual"])  # single-arm task(s)
    episodes: int = 50  # test seeds per task
    # test: the seeds reported numbers come from; validation: seeds for choosing between candidate priors (past every
    # validation demo's and the benchmark's validation rollouts'), so a choice never reads the test seeds
    split: Literal["test", "validation"] = "test"
    workers: int = 1  # parallel worker processes
    out: str = ""  # write a result JSON here (e.g. results/priors.json)
    log: str = ""  # per-episode log a stopped report resumes from (default: OUT with .episodes.jsonl)
    minutes: float = 0.0  # stop after this long and write an interim result (resume later with the same command)
    executor: Literal["local", "ray"] = "local"  # local worker processes, or Ray tasks on the cluster RAY_ADDRESS names


def prior_report(args: PriorReportArgs) -> None:
    from bimanualshift.data.seeds import PRIOR_CHOICE_START, split_seeds
    from bimanualshift.evaluation.priors import evaluate_priors, prior_rows
    from bimanualshift.evaluation.report import write_result
    from bimanualshift.evaluation.tables import print_prior_report

    names = resolve_tasks(args.task)
    started = time.time()
    seeds = split_seeds(args.split, args.episodes, start=PRIOR_CHOICE_START if args.split == "validation" else 0)
    log = args.log or (str(Path(args.out).with_suffix(".episodes.jsonl")) if args.out else None)
    deadline = started + 60 * args.minutes if args.minutes else None
    episodes = evaluate_priors(args.prior, names, seeds, workers=args.workers, log=log, deadline=deadline,
                               executor=args.executor)
    rows = prior_rows(args.prior, episodes, names, seeds[0])
    counts = sorted({t["episodes"] for r in rows for t in r["tasks"].values()})
    print_prior_report(rows, names, args.episodes)
    if args.out:
        notes = ("each prior drives the single arm alone (no projection, no residual); a rollout stops at twice the "
                 "expert's keyframe count on the same seed; inference is the median of 20 predict calls for one arm "
                 "with 2 torch threads")
        if counts != [args.episodes]:
            notes = (f"INTERIM: stopped by --minutes with {counts[0]}-{counts[-1]} of {args.episodes} {args.split} "
                     f"seeds per task done (per-episode log {log}); the same command without --minutes finishes it. "
                     + notes)
        write_result(args.out, command_line(), {args.split: seeds}, started, rows, notes=notes, episode_log=log)
        print(f"wrote {args.out}")


@dataclass
class PlotArgs:
    # result folders holding a summary.json, e.g. results/long_horizon
    folders: Annotated[list[str], tyro.conf.Positional, tyro.conf.arg(metavar="FOLDER")]


def plot(args: PlotArgs) -> None:
    from bimanualshift.evaluation.plots import redraw_plots

    for folder in args.folders:
        print(f"drew {', '.join(str(p) for p in redraw_plots(folder))}")


@dataclass
class ReportArgs:
    # files with results blocks (default: README.md and every docs/*.md holding one)
    readme: list[str] = field(default_factory=list)
    results: str = "results"  # results directory
    index: bool = False  # also write results/README.md: every result file's table


def report(args: ReportArgs) -> None:
    from bimanualshift.evaluation.readme import render_index, render_readme, results_documents

    if args.index:
        print(f"wrote {render_index(args.results)}")
    for readme in args.readme or results_documents():
        names = render_readme(readme, args.results)
        print(f"{readme}: regenerated {', '.join(names) if names else 'no results blocks'}")


@dataclass
class ExplainArgs:
    # a bench or study results folder (its episodes.jsonl and keyframes.jsonl)
    folder: Annotated[str, tyro.conf.Positional, tyro.conf.arg(metavar="FOLDER")]
    task: str  # the bimanual task whose failures to explain
    # only these methods (default: every one in the folder); --methods as in bench and study
    methods: Annotated[list[str], tyro.conf.arg(aliases=("--method",))] = field(default_factory=list)
    # also set each method's episodes against this method's on the same seeds, split by the source of the
    # reference retrieved (a demo or a refinement rollout): wins, losses and how far the executed keyframes moved
    against: str = ""
    # only the episodes tested under this perturbation (a generalisation folder holds several; default: all)
    perturbation: str = ""
    out: str = ""  # also write the rows as a JSON result file here


def explain(args: ExplainArgs) -> None:
    from bimanualshift.evaluation.explain import explain_rows, explain_text

    started = time.time()
    rows = explain_rows(args.folder, args.task, args.methods or None, args.against or None,
                        args.perturbation or None)
    print(explain_text(rows, args.task))
    if args.out:
        from bimanualshift.evaluation.explain import explained_seeds
        from bimanualshift.evaluation.report import write_result

        write_result(args.out, command_line(), explained_seeds(rows),
                     started, rows, notes=f"failures of {args.task} in {args.folder}", folder=args.folder,
                     task=args.task, against=args.against or None, perturbation=args.perturbation or None)
        print(f"wrote {args.out}")
