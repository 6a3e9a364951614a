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
import uuid
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from bimanualshift.configs import DEFAULT_PRIOR
from bimanualshift.data.seeds import split_seeds
from bimanualshift.evaluation.plots import bench_title, draw_plots
from bimanualshift.evaluation.shared_cells import (
    SAME_FOLDERS,
    check_shareable,
    count_shared,
    share_recorded,
    shared_records,
)
from bimanualshift.evaluation.stats import SuccessRate, SuccessRow, episode_key
from bimanualshift.evaluation.tables import bench_table, stage_table
from bimanualshift.registry import METHODS, REFINE_EPISODES, REFINE_FOLDER, MethodSpec, TrainRequest, get_method
from bimanualshift.rollout.loop import KEYFRAME_BUDGET
from bimanualshift.utils.io import atomic_write_json, atomic_write_text
from bimanualshift.utils.jsonl import append_record, read_records
from bimanualshift.utils.process_cache import cached
from bimanualshift.utils.workers import EXECUTORS, run_jobs

VALIDATION_ROLLOUT_START = 10_000  # validation rollouts' seeds: far past any validation demo's
DEFAULT_METHODS = ["bimanualshift", "no_projection", "no_residual", "no_retrieval", "no_refinement", "unstructured",
                   "paper_literal", "frozen_prior_per_arm", "scratch_voxel"]


@dataclass
class BenchConfig:
    tasks: list[str] = field(default_factory=lambda: ["bimanual"])  # task names or a group (bimanual)
    methods: list[str] = field(default_factory=lambda: list(DEFAULT_METHODS))
    demos: int = 30
    validation_demos: int = 5
    episodes: int = 100  # test seeds per task
    # "validation": roll out on validation seeds instead (design choices, e.g. the action-space residual against
    # the continuous one, are made there, never on test seeds); they start past the validation demos' seeds
    evaluate_on: str = "test"
    prior: str = DEFAULT_PRIOR  # the frozen single-arm prior: a shipped name or a checkpoint folder
    steps: int = 0  # training steps of every method not in method_steps; 0: each method's own (MethodSpec.steps)
    method_steps: dict = field(default_factory=lambda: {"scratch_voxel": 3000})  # per-method training steps
    workers: int = 2
    executor: str = "local"  # local: this machine's worker processes; ray: Ray tasks on a cluster (RAY_ADDRESS)
    data: str = "data/bench"
    runs: str = "runs/bench"
    out: str = "results/bench"
    videos: int = 1  # test episodes recorded per task and method
    log: Literal["none", "tensorboard", "wandb"] = "none"  # every trainer's curves, in its run folder (`train --log`)
    # record the --videos episodes for the rerun viewer too, merged into this .rrd (cameras, each arm's
    # projection, proposals and actions: `rerun FILE.rrd`)
    rrd: str = ""
    max_keyframes: int = 0  # a hard cap on episode length on top of the expert-relative budget (0: none)
    perturbations: list[str] = field(default_factory=lambda: ["none"])  # test-time presets (sim/perturbations.py)
    # Continual learning: a runs folder of one earlier task (runs/<bench>/<task>); every method that supports it
    # starts from its own run there (its weights and, for BimanualShift, its memory bank).
    continue_from: str = ""
    seed: int = 0  # training seed of every method (episode seeds are fixed per split)
    # refined methods (bimanualshift and its ablations but no_refinement) roll out on this many training scenes
    # after the demos' own, the expert correcting their failures, before they are evaluated
    refine_episodes: int = REFINE_EPISODES
    # methods to run again from scratch after a change to them: their recorded episodes and training runs move to
    # superseded/ folders named by the commit (evaluation/rerun.py); repeating the command resumes the re-run.
    # TASK/METHOD re-runs that one task of the method.
    rerun: list[str] = field(default_factory=list)
    # a results folder of another benchmark from the same runs, demos and settings (a study whose cells another
    # study already recorded): its episodes of this run's cells are copied here instead of rolled out again
    # (evaluation/shared_cells.py); the summary says how many
    share_from: str = ""


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
    rrd: str = ""  # also record this episode for the rerun viewer, into this part file
    rrd_id: str = ""  # the recording the parts merge into





def _request(cfg: BenchConfig, task: str, method: str, training: bool = True) -> TrainRequest:
    overrides = {}
    if cfg.continue_from and get_method(method).continual and training:
        earlier = Path(cfg.continue_from) / get_method(method).run_name
        if not earlier.is_dir():
            raise FileNotFoundError(f"continue_from={cfg.continue_from!r}: {method} has no earlier run at {earlier}; "
                                    "run the benchmark on the earlier task first")
        overrides["init_from"] = str(earlier)
    if get_method(method).refine:
        overrides["refine_episodes"] = cfg.refine_episodes
    return TrainRequest(task=task, data=f"{cfg.data}/train", validation_data=f"{cfg.data}/validation",
                        demos=cfg.demos, prior=cfg.prior, out=f"{cfg.runs}/{task}/{get_method(method).run_name}",
                        steps=int(cfg.method_steps.get(method) or cfg.steps or get_method(method).steps),
                        seed=cfg.seed, overrides=overrides, workers=cfg.workers, log=cfg.log)


# The settings that change what a recorded episode or a trained run measures. A results folder holds the episodes
# of one setting and a training run the weights of one request: reusing either under other settings would put,
# say, 30-demo episodes in a 100-demo table without a word.
EPISODE_SETTINGS = ("demos", "validation_demos", "prior", "steps", "method_steps", "max_keyframes", "seed",
                    "continue_from", "refine_episodes", "evaluate_on")
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


def check_training_run(request: TrainRequest, refine_folder: str = REFINE_FOLDER) -> None:
    """A training run is resumed or reused only for the request that started it (paths and workers aside: data and
    runs may move, and the number of processes changes nothing)."""
    settings = {k: v for k, v in asdict(request).items()
                if k not in ("data", "validation_data", "out", "workers", "log")}
    # refinement's settings belong to its own stage (``refine/``): the full method and its unrefined ablation
    # share the training run before it
    refine = {k: v for k, v in request.overrides.items() if k.startswith("refine_")}
    settings["overrides"] = {k: v for k, v in request.overrides.items() if k not in refine}
    fix = "give this run its own --runs, or delete that folder to retrain"
    _check_same(Path(request.out) / REQUEST_FILE, settings, None, "a training run", fix)
    if refine:
        _check_same(Path(request.out) / refine_folder / REQUEST_FILE, {**settings, **refine}, None,
                    "a refinement run", fix)


def check_model_behind_episodes(request: TrainRequest, method: str, recorded: int) -> None:
    """Episodes already recorded for (task, method) came from the model in ``request.out`` (its refinement folder
    for a refined method); with that run gone, training afresh would let a second model finish the first one's
    table (retraining the same settings moves a long task by several points), so the benchmark stops instead."""
    spec = get_method(method)
    run = Path(request.out) / spec.refine_folder if spec.refine else Path(request.out)
    if recorded and not (run / REQUEST_FILE).is_file():
        raise ValueError(f"{recorded} test episodes of {method} on {request.task} are recorded, but the training "
                         f"run they came from ({run}) is gone: a new model would finish another model's rows. "
                         f"Restore that folder, or pass --rerun {request.task}/{method} (this task) or "
                         f"--rerun {method} (every task) to evaluate its episodes with a new model "
                         "(the recorded ones are kept under superseded/)")


# "best": the fine-tuning step refinement handed on (step 0: the trained weights, unchanged) and its validation value
REFINEMENT_FIELDS = ("scenes", "policy_successes", "corrected_successes", "correction_samples",
                     "inserted_into_memory", "memory_entries", "best")


def _run_records(cfg: BenchConfig, tasks: list[str], folder: Callable[[MethodSpec], str | None],
                 fields: tuple[str, ...], marker: str) -> dict[str, dict[str, Any]]:
    """Per "task/method": ``fields`` of the summary.json in the method's run folder ``folder(spec)`` (under
    runs/<task>/; None: the method has no such folder), for summaries holding ``marker``."""
    out = {}
    for task in tasks:
        for method in cfg.methods:
            name = folder(get_method(method))
            path = Path(cfg.runs) / task / str(name) / "summary.json"
            if name is not None and path.is_file() and marker in (summary := json.loads(path.read_text())):
                out[f"{task}/{method}"] = {k: summary.get(k) for k in fields}
    return out


def refinement_records(cfg: BenchConfig, tasks: list[str]) -> dict[str, dict[str, Any]]:
    """Per "task/method" that was refined: its rollouts on training scenes, the failures the expert corrected into
    successes, the correction samples, the memory entries added and the fine-tuning step kept (from the run's
    refine/summary.json)."""
    return _run_records(cfg, tasks, lambda spec: f"{spec.run_name}/{spec.refine_folder}" if spec.refine else None,
                        REFINEMENT_FIELDS, "scenes")


TRAINING_FIELDS = ("best", "stopped_early_at", "validation_translation_error", "validation_rotation_error",
                   "output_gate")


def training_records(cfg: BenchConfig, tasks: list[str]) -> dict[str, dict[str, Any]]:
    """Per "task/method" trained by the residual trainer: the checkpoint it handed on (step, validation value),
    its validation translation error (prior alone and with the residual, overall and per keyframe) and the
    output gate's factors (from the run's summary.json; runs/ is not committed, this keeps them with the table)."""
    return _run_records(cfg, tasks, lambda spec: spec.run_name, TRAINING_FIELDS, "validation_translation_error")


def carried_records(summary: Path, field: str, fresh: dict[str, dict[str, Any]], episodes: list[dict[str, Any]]
                    ) -> dict[str, dict[str, Any]]:
    """``fresh`` (read from runs/) plus the earlier summary's ``field`` records of the task/method pairs that still
    have episodes in the folder and that runs/ no longer holds: runs/ is not committed, so re-tabulating on another
    machine (``--recorded-only``) or benchmarking one more method into the folder keeps the records of the runs
    behind the episodes already there. A pair retrained here is read afresh."""
    earlier = (json.loads(summary.read_text()).get(field) or {}) if summary.is_file() else {}
    tabled = {f"{e['task']}/{e['method']}" for e in episodes}
    kept = {k: v for k, v in earlier.items() if k in tabled and k not in fresh}
    return dict(sorted({**kept, **fresh}.items()))


def refinement_missing(refinement: dict[str, dict[str, Any]], episodes: list[dict[str, Any]]) -> list[str]:
    """The "task/method" pairs of refined methods whose episodes are in the folder but whose refinement record is
    not: their run is in no runs/ here and no earlier summary kept it (tabulated on another machine before the
    records were committed). The summary names them instead of leaving a silent gap."""
    refined = {f"{e['task']}/{e['method']}" for e in episodes if e["method"] in METHODS and METHODS[e["method"]].refine}
    return sorted(refined - set(refinement))


def run_bench_episode(job: BenchJob) -> dict[str, Any]:
    """One test episode in a worker (environments and loaded policies are cached per process)."""
    import torch

    from bimanualshift.evaluation.media import write_video
    from bimanualshift.rollout.loop import episode_budget, rollout
    from bimanualshift.sim.env_cache import cached_env

    torch.set_num_threads(1)  # one process per core
    env = cached_env(job.task, job.perturbation)
    # keyed by the whole request too: a method without a checkpoint (the frozen prior) is built from its prior, so two
    # benchmarks run in one process with other priors must not share it
    key = ("policy", job.method, job.task, job.checkpoint, json.dumps(job.request, sort_keys=True, default=str))
    policy = cached(key, lambda: get_method(job.method).load(
        Path(job.checkpoint) if job.checkpoint else None, TrainRequest(**job.request)))
    budget = episode_budget(env, job.seed, job.max_keyframes)
    recorder = None
    if job.rrd:
        from bimanualshift.evaluation.viewer import EpisodeRecorder

        recorder = EpisodeRecorder(job.rrd, recording_id=job.rrd_id)
    record = rollout(env, policy, job.seed, budget, record_camera="front" if job.video else None, observer=recorder)
    if recorder is not None:
        recorder.close()
    if job.video:
        write_video(job.video, record.frames)
    return {"task": job.task, "method": job.method, "perturbation": job.perturbation, "seed": job.seed,
            "success": record.success, "keyframes": record.keyframes, "budget": budget,
            "stages_done": record.stages_done, "instruction": record.instruction,
            "actions_sha256": record.actions_sha256, "steps": record.steps}


def record_episode(out: Path, episode: dict[str, Any]) -> None:
    """Append a finished episode to ``episodes.jsonl`` and its per-keyframe log to ``KEYFRAME_LOG`` (one line
    per episode, keyed like the episode), so the summary stays small and the log explains its failures."""
    steps = episode.pop("steps", None)
    if steps is not None:
        append_record(out / KEYFRAME_LOG, {k: episode[k] for k in ("task", "method", "perturbation", "seed")}
                      | {"steps": steps})
    append_episode(out / "episodes.jsonl", episode)


read_episodes = read_records  # one finished episode per line
KEYFRAME_LOG = "keyframes.jsonl"  # per episode: every keyframe's actions, the expert's and the policy's own log
RRD_PARTS = "rerun_parts"  # each recorded episode's .rrd, before they are merged into --rrd
append_episode = append_record


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
                rate = SuccessRate.of(e["success"] for e in mine)
                rates.append((rate.successes, rate.episodes))
                mine_rows.append(SuccessRow(task, method, rate, context={"demos": demos},
                                            details=stage_success(task, mine)).to_dict())
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
    pooled = SuccessRate(sum(r[0] for r in rates), sum(r[1] for r in rates))
    row = SuccessRow("average", method, pooled, context={"demos": demos}).to_dict()
    return {**row, "success": round(float(np.mean([a / b for a, b in rates])), 4)}


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
        rate = SuccessRate.of(int(e.get("stages_done", 0)) > i for e in episodes).fields()
        out.append({"stage": name, "success": rate["success"], "ci95": rate["ci95"]})
    return {"stages": out}


def bench_seeds(cfg: BenchConfig) -> dict[str, list[int]]:
    """The run's seeds per split; "test" names the seeds the methods are rolled out on (validation seeds with
    ``evaluate_on="validation"``: the summary records which split they are)."""
    return {"train": split_seeds("train", cfg.demos), "validation": split_seeds("validation", cfg.validation_demos),
            "test": split_seeds("test", cfg.episodes) if cfg.evaluate_on == "test"
            else split_seeds("validation", cfg.episodes, VALIDATION_ROLLOUT_START)}


def _all_recorded(done: set[tuple[str, str, str, int]], method: str, tasks: list[str], perturbations: list[str],
                  seeds: list[int]) -> bool:
    """Whether every rollout of ``method`` (task, perturbation, seed) is in ``done``; never with no seeds
    (``--episodes 0`` asks for training only)."""
    return bool(seeds) and all((t, method, p, s) in done for t in tasks for p in perturbations for s in seeds)


def recorded_counts(cfg: BenchConfig) -> dict[tuple[str, str], tuple[int, int]]:
    """Per (task, method) of the run: its rollouts (perturbation, test seed) in ``episodes.jsonl`` (or in the
    folder it shares cells from) and planned."""
    from bimanualshift.sim.task_registry import resolve_task_names

    done = {episode_key(e) for e in read_episodes(Path(cfg.out) / "episodes.jsonl")}
    if cfg.share_from:  # the cells run_bench would copy before rolling anything out count as recorded
        done |= {episode_key(e) for e in read_episodes(Path(cfg.share_from) / "episodes.jsonl")}
    seeds = bench_seeds(cfg)["test"]
    planned = len(seeds) * len(cfg.perturbations)
    return {(t, m): (sum((t, m, p, s) in done for p in cfg.perturbations for s in seeds), planned)
            for t in resolve_task_names(cfg.tasks) for m in cfg.methods}


def recorded_methods(cfg: BenchConfig) -> list[str]:
    """The run's methods whose every rollout (task, perturbation, seed) is already in its ``episodes.jsonl``; none
    with no test seeds (``--episodes 0`` asks for training only)."""
    if not bench_seeds(cfg)["test"]:
        return []
    counts = recorded_counts(cfg)
    return [m for m in cfg.methods if all(done == planned for (_, method), (done, planned) in counts.items()
                                          if method == m)]


def run_bench(cfg: BenchConfig, command: str | None = None, started: float | None = None) -> Path:
    """Run (or resume) one benchmark folder: collect, train, roll out what is not recorded, then write its table,
    plots and summary. ``started`` (default: now) is when the invocation began, for the summary's wall time."""
    from bimanualshift.data.collect import collect
    from bimanualshift.evaluation.report import write_result
    from bimanualshift.evaluation.tables import print_success_table
    from bimanualshift.sim.task_registry import resolve_task_names, task_names

    if cfg.executor not in EXECUTORS:  # before any training, not after it
        raise ValueError(f"--executor {cfg.executor!r} is not one of {', '.join(EXECUTORS)}")
    started = started or time.time()
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
    if cfg.evaluate_on not in ("test", "validation"):
        raise ValueError(f"evaluate_on must be test or validation, got {cfg.evaluate_on!r}")
    seeds = bench_seeds(cfg)
    if cfg.rerun:
        from bimanualshift.evaluation.report import git_commit
        from bimanualshift.evaluation.rerun import supersede_all

        supersede_all(cfg.rerun, cfg.methods, out, cfg.runs, tasks, git_commit())

    jobs = []
    # the parts the workers write merge into one recording (episodes already recorded: `bimanualshift view`)
    rrd_id = str(uuid.uuid5(uuid.NAMESPACE_URL, str(out.resolve())))
    from bimanualshift.sim.perturbations import preset

    for name in cfg.perturbations:
        preset(name)  # an unknown preset fails before any work
    log = out / "episodes.jsonl"
    if cfg.share_from:
        source = Path(cfg.share_from)
        check_shareable(source, {k: getattr(cfg, k) for k in EPISODE_SETTINGS}, {k: getattr(cfg, k)
                        for k in SAME_FOLDERS}, SETTINGS_FILE)
        copied = share_recorded(source, out, [(t, m, p, s) for t in tasks for m in cfg.methods
                                              for p in cfg.perturbations for s in seeds["test"]], KEYFRAME_LOG)
        if copied:
            print(f"[bench] {copied} episodes shared from {source} (same runs, demos and settings)")
    done = {episode_key(e) for e in read_episodes(log)}
    for task in tasks:
        # A method whose every test episode is already recorded is neither retrained nor re-collected for, so
        # adding a method to a finished run costs only that method.
        pending = [m for m in cfg.methods if not _all_recorded(done, m, [task], cfg.perturbations, seeds["test"])]
        if pending:
            collect([task], seeds["train"], f"{cfg.data}/train", workers=cfg.workers)
            collect([task], seeds["validation"], f"{cfg.data}/validation", workers=cfg.workers)
        for method in cfg.methods:
            request = _request(cfg, task, method, training=method in pending)
            if method in pending:
                recorded = sum(1 for k in done if k[:2] == (task, method))
                check_model_behind_episodes(request, method, recorded)
                check_training_run(request, get_method(method).refine_folder)
                checkpoint = get_method(method).train(request)
            else:
                print(f"[bench] {task} / {method}: every test episode is recorded; not retrained")
                checkpoint = None
            for perturbation in cfg.perturbations:
                for i, seed in enumerate(seeds["test"]):
                    suffix = "" if perturbation == "none" else f"_{perturbation}"
                    video = str(out / "videos" / f"{task}_{method}{suffix}_{seed}.mp4") if i < cfg.videos else ""
                    part = str(out / RRD_PARTS / f"{task}_{method}{suffix}_{seed}.rrd") if video and cfg.rrd else ""
                    jobs.append(BenchJob(method, task, seed, str(checkpoint or ""), asdict(request), video,
                                         cfg.max_keyframes, perturbation, part, rrd_id))

    todo = [j for j in jobs if (j.task, j.method, j.perturbation, j.seed) not in done]
    if done:
        print(f"[bench] resuming: {len(done)} episodes already recorded, {len(todo)} to go")
    run_jobs(run_bench_episode, todo, cfg.workers, desc="bench episodes", chunksize=1, executor=cfg.executor,
             on_result=lambda episode: record_episode(out, episode))

    parts = sorted((out / RRD_PARTS).glob("*.rrd")) if cfg.rrd else []
    if parts:
        from bimanualshift.evaluation.viewer import merge_recordings

        print(f"[bench] wrote {merge_recordings(parts, cfg.rrd)}: {len(parts)} episodes (`rerun {cfg.rrd}`)")
    elif cfg.rrd:
        print(f"[bench] no episode ran here to record into {cfg.rrd}; `bimanualshift view {out}` writes recorded ones")
    wanted = {(j.task, j.method, j.perturbation, j.seed) for j in jobs}
    episodes = [e for e in read_episodes(log) if episode_key(e) in wanted]
    rows = bench_rows(episodes, cfg.methods, tasks, cfg.demos, cfg.perturbations)
    print_success_table(rows, f"bench: {cfg.demos} demos, {cfg.episodes} {cfg.evaluate_on} episodes per task")
    if rows:  # (none when only training was asked for: --episodes 0)
        draw_plots(out, rows, bench_title(cfg.demos, cfg.episodes, cfg.evaluate_on))
        atomic_write_text(out / "table.md", bench_table(rows) + "\n" + stage_table(rows))
    recorded_episodes = read_episodes(log)
    recorded = seeds if cfg.evaluate_on == "test" else {
        "train": seeds["train"], "validation": seeds["validation"], "validation_rollouts": seeds["test"]}
    shared: dict[str, Any] = {}
    fresh_refinement, fresh_training = refinement_records(cfg, tasks), training_records(cfg, tasks)
    if cfg.share_from:  # the shared cells' runs are the source's: its records stand where runs/ holds none
        source, pairs = Path(cfg.share_from), {f"{e['task']}/{e['method']}" for e in episodes}
        shared = {"shared_from": {"folder": cfg.share_from, "episodes": count_shared(source, episodes)}}
        fresh_refinement = {**shared_records(source, "refinement", pairs), **fresh_refinement}
        fresh_training = {**shared_records(source, "training", pairs), **fresh_training}
    refinement = carried_records(out / "summary.json", "refinement", fresh_refinement, recorded_episodes)
    if missing := refinement_missing(refinement, recorded_episodes):
        print(f"[bench] no refinement record for {', '.join(missing)}: their runs are not under {cfg.runs} and no "
              "earlier summary.json here kept them (listed as refinement_missing)")
    write_result(out / "summary.json", command, recorded, started, rows, bench=True, config=asdict(cfg),
                 refinement=refinement, refinement_missing=missing,
                 training=carried_records(out / "summary.json", "training", fresh_training, recorded_episodes),
                 **shared,
                 methods={m: METHODS[m].description for m in cfg.methods},
                 notes=f"prior {cfg.prior}; episodes stop at {KEYFRAME_BUDGET}x the expert's keyframes on the "
                       "same seed; wall time covers this invocation only (a resumed run reuses earlier work)")
    return out / "summary.json"
