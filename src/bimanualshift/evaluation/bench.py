"""`bimanualshift bench`: methods x tasks on fixed, disjoint seeds, resumable, with a table, a plot and videos.

For every task: expert demos on train seeds (the first ``demos``) and validation seeds (checkpoint choice);
every method is trained on them (methods that train nothing skip this) and rolled out on the same test seeds.
Each finished episode is appended to ``episodes.jsonl`` at once, so a killed run continues where it stopped;
trained runs resume from their own checkpoints. The summary (``summary.json``, the results envelope), a
Table-I-style markdown table, a bar plot and a few rollout videos are written at the end.
"""

from __future__ import annotations

import json
import shlex
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bimanualshift.data.seeds import split_seeds
from bimanualshift.evaluation.stats import wilson_interval
from bimanualshift.methods.registry import METHODS, TrainRequest, get_method
from bimanualshift.utils.io import atomic_write_json, atomic_write_text
from bimanualshift.utils.jsonl import append_record, read_records
from bimanualshift.utils.workers import EXECUTORS, run_jobs

KEYFRAME_BUDGET = 2  # an episode stops at this multiple of the expert's keyframe count on the same seed
DEFAULT_METHODS = ["bimanualshift", "no_projection", "no_residual", "no_retrieval", "unstructured",
                   "frozen_prior_per_arm", "scratch_voxel"]


@dataclass
class BenchConfig:
    tasks: list[str] = field(default_factory=lambda: ["bimanual"])  # task names or a group (bimanual)
    methods: list[str] = field(default_factory=lambda: list(DEFAULT_METHODS))
    demos: int = 30
    validation_demos: int = 5
    episodes: int = 100  # test seeds per task
    prior: str = "peract_suite"
    residual_steps: int = 0  # training steps of every method; 0: each method's own (MethodSpec.steps, else 1500)
    method_steps: dict = field(default_factory=lambda: {"scratch_voxel": 3000})  # per-method training steps
    workers: int = 2
    executor: str = "local"  # local: this machine's worker processes; ray: Ray tasks on a cluster (RAY_ADDRESS)
    data: str = "data/bench"
    runs: str = "runs/bench"
    out: str = "results/bench"
    videos: int = 1  # test episodes recorded per task and method
    max_keyframes: int = 0  # a hard cap on episode length on top of the expert-relative budget (0: none)
    perturbations: list[str] = field(default_factory=lambda: ["none"])  # test-time presets (sim/perturbations.py)
    # Continual learning: a runs folder of one earlier task (runs/<bench>/<task>); every method that supports it
    # starts from its own run there (its weights and, for BimanualShift, its memory bank).
    continue_from: str = ""
    seed: int = 0


@dataclass(frozen=True)
class BenchJob:
    method: str
    task: str
    seed: int
    checkpoint: str  # "" when the method trains nothing
    request: dict[str, Any]
    video: str = ""  # write this episode's front-camera video here
    max_keyframes: int = 0
    perturbation: str = "none"


DEFAULT_TRAIN_STEPS = 1500  # for methods that name no steps of their own

_CACHE: dict[Any, Any] = {}


def _request(cfg: BenchConfig, task: str, method: str, training: bool = True) -> TrainRequest:
    overrides = {}
    if cfg.continue_from and get_method(method).continual and training:
        earlier = Path(cfg.continue_from) / method
        if not earlier.is_dir():
            raise FileNotFoundError(f"continue_from={cfg.continue_from!r}: {method} has no earlier run at {earlier}; "
                                    "run the benchmark on the earlier task first")
        overrides["init_from"] = str(earlier)
    return TrainRequest(task=task, data=f"{cfg.data}/train", validation_data=f"{cfg.data}/validation",
                        demos=cfg.demos, prior=cfg.prior, out=f"{cfg.runs}/{task}/{method}",
                        steps=int(cfg.method_steps.get(method) or cfg.residual_steps or get_method(method).steps
                                  or DEFAULT_TRAIN_STEPS),
                        seed=cfg.seed,
                        overrides=overrides)


# The settings that change what a recorded episode or a trained run measures. A results folder holds the episodes
# of one setting and a training run the weights of one request: reusing either under other settings would put,
# say, 30-demo episodes in a 100-demo table without a word.
EPISODE_SETTINGS = ("demos", "validation_demos", "prior", "residual_steps", "method_steps", "max_keyframes", "seed",
                    "continue_from")
SETTINGS_FILE = "bench_settings.json"
REQUEST_FILE = "bench_request.json"


def _check_same(path: Path, settings: dict[str, Any], earlier: dict[str, Any] | None, what: str, fix: str) -> None:
    """Refuse to reuse ``path``'s folder when its earlier settings differ from these; record them otherwise."""
    if earlier is None and path.is_file():
        earlier = json.loads(path.read_text())
    if earlier is not None:
        differ = {k: (earlier[k], v) for k, v in settings.items() if k in earlier and earlier[k] != v}
        if differ:
            listed = "; ".join(f"{k}={old!r} there, {new!r} now" for k, (old, new) in differ.items())
            raise ValueError(f"{path.parent} holds {what} made with other settings ({listed}): {fix}")
    atomic_write_json(path, {**(earlier or {}), **settings})


def check_results_folder(cfg: BenchConfig) -> None:
    """A results folder is reused (resumed, extended by methods) only under the settings its episodes came from.
    Folders written before the settings file existed are checked against their summary's config."""
    out = Path(cfg.out)
    legacy = None
    if not (out / SETTINGS_FILE).is_file() and (out / "summary.json").is_file():
        config = json.loads((out / "summary.json").read_text()).get("config") or {}
        legacy = {k: config[k] for k in EPISODE_SETTINGS if k in config} or None
    _check_same(out / SETTINGS_FILE, {k: getattr(cfg, k) for k in EPISODE_SETTINGS}, legacy, "episodes",
                "give this run its own --out (and --runs; `study`: --results), or delete that folder to start over")


def check_training_run(request: TrainRequest) -> None:
    """A training run is resumed or reused only for the request that started it (paths aside: data and runs may
    move)."""
    settings = {k: v for k, v in asdict(request).items() if k not in ("data", "validation_data", "out")}
    _check_same(Path(request.out) / REQUEST_FILE, settings, None, "a training run",
                "give this run its own --runs, or delete that folder to retrain")


def run_bench_episode(job: BenchJob) -> dict[str, Any]:
    """One test episode in a worker (environments and loaded policies are cached per process)."""
    import torch

    from bimanualshift.evaluation.media import write_video
    from bimanualshift.evaluation.rollout import rollout
    from bimanualshift.sim.env import ManipulationEnv

    torch.set_num_threads(1)  # one process per core
    from bimanualshift.sim.perturbations import preset

    env_key = ("env", job.task, job.perturbation)
    if env_key not in _CACHE:
        _CACHE[env_key] = ManipulationEnv(job.task, perturbations=preset(job.perturbation))
    env = _CACHE[env_key]
    key = ("policy", job.method, job.task, job.checkpoint)
    if key not in _CACHE:
        request = TrainRequest(**job.request)
        _CACHE[key] = get_method(job.method).load(Path(job.checkpoint) if job.checkpoint else None, request)
    env.reset(seed=job.seed, options={"render": False})
    budget = KEYFRAME_BUDGET * len(env.expert_keyframes())
    budget = min(budget, job.max_keyframes) if job.max_keyframes else budget
    record = rollout(env, _CACHE[key], job.seed, budget, record_camera="front" if job.video else None)
    if job.video:
        write_video(job.video, record.frames)
    return {"task": job.task, "method": job.method, "perturbation": job.perturbation, "seed": job.seed,
            "success": record.success, "keyframes": record.keyframes, "budget": budget,
            "stages_done": record.stages_done, "instruction": record.instruction}


read_episodes = read_records  # one finished episode per line
append_episode = append_record


def _key(e: dict[str, Any]) -> tuple[str, str, str, int]:
    return e["task"], e["method"], e.get("perturbation", "none"), e["seed"]


def bench_rows(episodes: list[dict[str, Any]], methods: list[str], tasks: list[str], demos: int,
               perturbations: list[str] = ("none",)) -> list[dict[str, Any]]:
    """Success per (task, method[, perturbation]) with Wilson 95 % intervals, then each method's average over
    the tasks. Under a perturbation, ``degradation`` is the relative drop from the unperturbed success."""
    rows = []
    for perturbation in perturbations:
        for method in methods:
            mine_rows, rates = [], []
            for task in tasks:
                mine = [e for e in episodes if e["method"] == method and e["task"] == task
                        and e.get("perturbation", "none") == perturbation]
                if not mine:
                    continue
                k = sum(e["success"] for e in mine)
                lo, hi = wilson_interval(k, len(mine))
                rates.append((k, len(mine)))
                mine_rows.append({"task": task, "method": method, "demos": demos,
                                  "success": round(k / len(mine), 4), "episodes": len(mine),
                                  "ci95": [round(lo, 4), round(hi, 4)], **stage_success(task, mine)})
            if len(rates) > 1:
                mine_rows.append(average_row(method, demos, rates))
            if list(perturbations) != ["none"]:
                for r in mine_rows:
                    r["perturbation"] = perturbation
            rows += mine_rows
    if list(perturbations) != ["none"]:
        clean = {(r["task"], r["method"]): r["success"] for r in rows if r["perturbation"] == "none"}
        for r in rows:
            base = clean.get((r["task"], r["method"]))
            if r["perturbation"] != "none" and base:
                r["degradation"] = round((base - r["success"]) / base, 4)
    return rows


def average_row(method: str, demos: int | str, rates: list[tuple[int, int]]) -> dict[str, Any]:
    """A method's average over tasks from (successes, episodes) per task: the mean of the per-task rates (each
    task weighs the same, as in the paper's Table I), with a Wilson interval on the pooled episodes."""
    k, n = sum(r[0] for r in rates), sum(r[1] for r in rates)
    lo, hi = wilson_interval(k, n)
    return {"task": "average", "method": method, "demos": demos,
            "success": round(float(np.mean([a / b for a, b in rates])), 4), "episodes": n,
            "ci95": [round(lo, 4), round(hi, 4)]}


def stage_success(task: str, episodes: list[dict[str, Any]]) -> dict[str, Any]:
    """For a multi-stage task, the share of episodes that reached each stage (in order), with Wilson 95 %
    intervals: ``{"stages": [{"stage", "success", "ci95"}, ...]}``; nothing for a single-stage task."""
    from bimanualshift.sim import tasks  # noqa: F401 - importing registers every task
    from bimanualshift.sim.task import TASKS

    names = TASKS[task].stage_names if task in TASKS else ()
    if not names:
        return {}
    out = []
    for i, name in enumerate(names):
        k = sum(int(e.get("stages_done", 0)) > i for e in episodes)
        lo, hi = wilson_interval(k, len(episodes))
        out.append({"stage": name, "success": round(k / len(episodes), 4), "ci95": [round(lo, 4), round(hi, 4)]})
    return {"stages": out}


def stage_table(rows: list[dict[str, Any]]) -> str:
    """Stage-wise success (Table III / Fig. 11b layout): one row per method and task, one column per stage."""
    staged = [r for r in rows if r.get("stages")]
    if not staged:
        return ""
    lines = []
    for task in dict.fromkeys(r["task"] for r in staged):
        mine = [r for r in staged if r["task"] == task]
        names = [s["stage"] for s in mine[0]["stages"]]
        lines += [f"**{task.replace('_', ' ')}: stage-wise success (%)**", "",
                  "| method | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
        for r in mine:
            extra = f" ({100 * r['degradation']:.0f} % degradation)" if "degradation" in r else ""
            lines.append(f"| {row_label(r)}{extra} | " + " | ".join(f"{100 * s['success']:.0f}" for s in r["stages"])
                         + " |")
        lines.append("")
    return "\n".join(lines)


def row_label(row: dict[str, Any]) -> str:
    """The method, the study run it belongs to and the perturbation it was tested under, where there are some."""
    return (row["method"] + (f" [{row['run']}]" if "run" in row else "")
            + (f" ({row['perturbation']})" if "perturbation" in row else ""))


def bench_table(rows: list[dict[str, Any]]) -> str:
    """Table I's layout: one row per method (and perturbation), one column per task, then the average."""
    tasks = list(dict.fromkeys(r["task"] for r in rows))
    methods = list(dict.fromkeys(row_label(r) for r in rows))
    cell = {(row_label(r), r["task"]): r for r in rows}
    lines = ["| method | " + " | ".join(t.replace("_", " ") for t in tasks) + " |", "|---|" + "---|" * len(tasks)]
    for method in methods:
        cells = []
        for task in tasks:
            r = cell.get((method, task))
            cells.append("–" if r is None else
                         f"{100 * r['success']:.0f} ({100 * r['ci95'][0]:.0f}–{100 * r['ci95'][1]:.0f})")
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def bar_plot(path: Path, rows: list[dict[str, Any]], title: str) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bimanualshift.utils.io import atomic_writer

    tasks = list(dict.fromkeys(r["task"] for r in rows))
    methods = list(dict.fromkeys(row_label(r) for r in rows))
    cell = {(row_label(r), r["task"]): r for r in rows}
    width = 0.8 / len(methods)
    fig, ax = plt.subplots(figsize=(max(6.0, 1.6 * len(tasks)), 3.8))
    for i, method in enumerate(methods):
        xs, ys, err = [], [], [[], []]
        for j, task in enumerate(tasks):
            r = cell.get((method, task))
            if r is None:
                continue
            xs.append(j + (i - (len(methods) - 1) / 2) * width)
            ys.append(100 * r["success"])
            err[0].append(100 * (r["success"] - r["ci95"][0]))
            err[1].append(100 * (r["ci95"][1] - r["success"]))
        ax.bar(xs, ys, width, yerr=err, capsize=2, label=method)
    ax.set_xticks(range(len(tasks)), [t.replace("_", "\n") for t in tasks], fontsize=8)
    ax.set_ylabel("success (%)")
    ax.set_ylim(0, 100)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=7, ncols=min(len(methods), 3))
    fig.tight_layout()
    with atomic_writer(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    plt.close(fig)
    return path


def stage_plot(path: Path, rows: list[dict[str, Any]], title: str) -> Path | None:
    """Stage-wise success (Fig. 11b's layout): per multi-stage task, one line per method over its stages with
    Wilson 95 % bands; None (nothing written) when no row has stages."""
    staged = [r for r in rows if r.get("stages")]
    if not staged:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bimanualshift.utils.io import atomic_writer

    tasks = list(dict.fromkeys(r["task"] for r in staged))
    fig, axes = plt.subplots(1, len(tasks), figsize=(5.5 * len(tasks), 3.8), squeeze=False)
    for ax, task in zip(axes[0], tasks):
        mine = [r for r in staged if r["task"] == task]
        names = [s["stage"] for s in mine[0]["stages"]]
        xs = list(range(len(names)))
        for r in mine:
            ys = [100 * s["success"] for s in r["stages"]]
            low = [100 * s["ci95"][0] for s in r["stages"]]
            high = [100 * s["ci95"][1] for s in r["stages"]]
            (line,) = ax.plot(xs, ys, marker="o", label=row_label(r))
            ax.fill_between(xs, low, high, alpha=0.12, color=line.get_color())
        ax.set_xticks(xs, [n.replace(" ", "\n") for n in names], fontsize=8)
        ax.set_ylim(0, 100)
        ax.set_ylabel("episodes reaching the stage (%)")
        ax.set_title(f"{title}: {task.replace('_', ' ')}", fontsize=10)
        ax.legend(fontsize=7)
    fig.tight_layout()
    with atomic_writer(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    plt.close(fig)
    return path


def draw_plots(out: Path, rows: list[dict[str, Any]], title: str) -> None:
    """A result folder's plots: success bars and, for multi-stage tasks, the stage-wise lines."""
    bar_plot(out / "success.png", rows, title)
    stage_plot(out / "stages.png", rows, title)


def redraw_plots(folder: str | Path) -> list[Path]:
    """Redraw the plots of a bench or study result folder from its ``summary.json``."""
    folder = Path(folder)
    summary = folder / "summary.json"
    if not summary.is_file():
        raise FileNotFoundError(f"no summary.json in {folder}: give a folder written by `bimanualshift bench` or "
                                "`bimanualshift study`")
    result = json.loads(summary.read_text())
    if not result.get("rows") or "task" not in result["rows"][0]:
        raise ValueError(f"{summary} holds no benchmark rows (task, method, success); it is not a bench result")
    first = result["rows"][0]
    title = (f"study {result['study']}" if result.get("study") else f"{first.get('demos', '?')} demos, "
             f"{first.get('episodes', '?')} test episodes per task (95 % Wilson intervals)")
    draw_plots(folder, result["rows"], title)
    return [p for p in (folder / "success.png", folder / "stages.png") if p.is_file()]


def run_bench(cfg: BenchConfig, command: str | None = None) -> Path:
    from bimanualshift.data.collect import collect
    from bimanualshift.evaluation.report import print_success_table, write_result
    from bimanualshift.sim.task import resolve_task_names, task_names

    if cfg.executor not in EXECUTORS:  # before any training, not after it
        raise ValueError(f"--executor {cfg.executor!r} is not one of {', '.join(EXECUTORS)}")
    started = time.time()
    command = command or " ".join(["bimanualshift bench", *(shlex.quote(a) for a in sys.argv[2:])])
    tasks = resolve_task_names(cfg.tasks)
    single = [t for t in tasks if t not in task_names(bimanual=True)]
    if single:
        raise ValueError(f"{single} are single-arm tasks; the benchmark compares bimanual methods "
                         "(measure priors with `bimanualshift prior-report`)")
    for method in cfg.methods:
        get_method(method)
    out = Path(cfg.out)
    (out / "videos").mkdir(parents=True, exist_ok=True)
    check_results_folder(cfg)
    seeds = {"train": split_seeds("train", cfg.demos), "validation": split_seeds("validation", cfg.validation_demos),
             "test": split_seeds("test", cfg.episodes)}

    jobs = []
    from bimanualshift.sim.perturbations import preset

    for name in cfg.perturbations:
        preset(name)  # an unknown preset fails before any work
    log = out / "episodes.jsonl"
    done = {_key(e) for e in read_episodes(log)}
    for task in tasks:
        # A method whose every test episode is already recorded is neither retrained nor re-collected for, so
        # adding a method to a finished run costs only that method.
        pending = [m for m in cfg.methods if not seeds["test"]  # --episodes 0: training only
                   or any((task, m, p, s) not in done for p in cfg.perturbations for s in seeds["test"])]
        if pending:
            collect([task], seeds["train"], f"{cfg.data}/train", workers=cfg.workers)
            collect([task], seeds["validation"], f"{cfg.data}/validation", workers=cfg.workers)
        for method in cfg.methods:
            request = _request(cfg, task, method, training=method in pending)
            if method in pending:
                check_training_run(request)
                checkpoint = get_method(method).train(request)
            else:
                print(f"[bench] {task} / {method}: every test episode is recorded; not retrained")
                checkpoint = None
            for perturbation in cfg.perturbations:
                for i, seed in enumerate(seeds["test"]):
                    suffix = "" if perturbation == "none" else f"_{perturbation}"
                    video = str(out / "videos" / f"{task}_{method}{suffix}_{seed}.mp4") if i < cfg.videos else ""
                    jobs.append(BenchJob(method, task, seed, str(checkpoint or ""), asdict(request), video,
                                         cfg.max_keyframes, perturbation))

    todo = [j for j in jobs if (j.task, j.method, j.perturbation, j.seed) not in done]
    if done:
        print(f"[bench] resuming: {len(done)} episodes already recorded, {len(todo)} to go")
    run_jobs(run_bench_episode, todo, cfg.workers, desc="bench episodes", chunksize=1, executor=cfg.executor,
             on_result=lambda episode: append_episode(log, episode))

    wanted = {(j.task, j.method, j.perturbation, j.seed) for j in jobs}
    episodes = [e for e in read_episodes(log) if _key(e) in wanted]
    rows = bench_rows(episodes, cfg.methods, tasks, cfg.demos, cfg.perturbations)
    print_success_table(rows, f"bench: {cfg.demos} demos, {cfg.episodes} test episodes per task")
    if rows:  # (none when only training was asked for: --episodes 0)
        title = f"{cfg.demos} demos, {cfg.episodes} test episodes per task (95 % Wilson intervals)"
        draw_plots(out, rows, title)
        atomic_write_text(out / "table.md", bench_table(rows) + "\n" + stage_table(rows))
    write_result(out / "summary.json", command, seeds, started, rows, bench=True, config=asdict(cfg),
                 methods={m: METHODS[m].description for m in cfg.methods},
                 notes=f"prior {cfg.prior}; episodes stop at {KEYFRAME_BUDGET}x the expert's keyframes on the "
                       "same seed; wall time covers this invocation only (a resumed run reuses earlier work)")
    return out / "summary.json"
