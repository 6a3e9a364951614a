"""The paper's studies as named lists of benchmark runs (`bimanualshift study NAME`).

Each study is one or more ``BenchConfig``s run in order (each resumable on its own) and then combined into
``results/<study>/summary.json`` (rows labelled by the run they came from), a table and a plot. Flags given to
`study` override every run of the study (e.g. ``--episodes 20 --workers 2`` for a quicker pass; the result file
records the overrides in its command).
"""

from __future__ import annotations

import json
import shlex
import sys
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from bimanualshift.evaluation.bench import (
    EPISODE_SETTINGS,
    BenchConfig,
    average_row,
    recorded_counts,
    recorded_methods,
    run_bench,
)
from bimanualshift.evaluation.plots import draw_plots
from bimanualshift.evaluation.shared_cells import SAME_FOLDERS
from bimanualshift.evaluation.tables import stage_table, study_table, targets_table
from bimanualshift.evaluation.targets import paired_with_full, study_targets
from bimanualshift.registry import methods_with_role
from bimanualshift.sim.perturbations import PRESETS
from bimanualshift.sim.task_registry import resolve_task_names, task_groups
from bimanualshift.utils.io import atomic_write_text

# Table I's rows: the full method, every baseline, every ablation and the frozen prior on its own (the registry
# says which is which)
TABLE1_METHODS = ["bimanualshift", *methods_with_role("baseline", "from_scratch", "ablation", "reference")]
FEW_SHOT_TASKS = ["push_two_buttons", "lift_ball", "pick_up_plate"]
TABLE1_TASKS = ("take_tray_out_of_oven", "straighten_rope", "sweep_to_dustpan", "lift_ball", "push_two_buttons",
                "pick_up_plate")  # the paper's six RLBench2 tasks (the composite task is the long-horizon study's)
TABLE1 = "all tasks"  # both halves of Table I share one label: one row per method over the six tasks


@dataclass(frozen=True)
class Study:
    """A named study: its benchmark runs as (label, config), ``out`` relative to the results folder."""

    name: str
    about: str
    runs: tuple[tuple[str, BenchConfig], ...]


LONG_HORIZON_METHODS = ["bimanualshift", "no_retrieval", "peract_lf"]
LONG_HORIZON_RUNS = "runs/long_horizon"

# Every study, by name (openpi's named-config table): `bimanualshift study NAME` runs one.
_STUDIES = [
    Study("table1", "Table I: the complex tasks at 30 demos, the simpler ones at 100; one row per method (folders "
          "are named by their tasks, not their demos: `--demos` overrides both halves)", (
              (TABLE1, BenchConfig(tasks=list(TABLE1_TASKS[:3]), demos=30, methods=TABLE1_METHODS,
                                   out="table1/complex_tasks", runs="runs/table1")),
              (TABLE1, BenchConfig(tasks=list(TABLE1_TASKS[3:]), demos=100, methods=TABLE1_METHODS,
                                   out="table1/simpler_tasks", runs="runs/table1")))),
    Study("few_shot", "Fig. 11a: 5 / 15 / 30 demos", tuple(
        (f"{n} demos", BenchConfig(tasks=FEW_SHOT_TASKS, demos=n, methods=["bimanualshift", "peract_lf"],
                                   out=f"few_shot/demos_{n}", runs=f"runs/few_shot_{n}")) for n in (5, 15, 30))),
    Study("generalisation", "Table III: the seven perturbations on one task (overall success)", (
        ("perturbations", BenchConfig(tasks=["take_tray_out_of_oven"], demos=30, methods=["bimanualshift", "peract_lf"],
                                      perturbations=list(PRESETS), out="generalisation/perturbations",
                                      runs="runs/generalisation")),)),
    Study("long_horizon", "Fig. 11b: two tasks learnt in turn, then a four-stage composite from 5 demos", (
        ("task 1", BenchConfig(tasks=["push_two_buttons"], demos=30, methods=LONG_HORIZON_METHODS, episodes=20,
                               out="long_horizon/task1", runs=f"{LONG_HORIZON_RUNS}/task1")),
        ("task 2", BenchConfig(tasks=["lift_ball"], demos=30, methods=LONG_HORIZON_METHODS, episodes=20,
                               out="long_horizon/task2", runs=f"{LONG_HORIZON_RUNS}/task2",
                               continue_from=f"{LONG_HORIZON_RUNS}/task1/push_two_buttons")),
        ("composite", BenchConfig(tasks=["buttons_then_lift_ball"], demos=5, methods=LONG_HORIZON_METHODS,
                                  out="long_horizon/composite", runs=f"{LONG_HORIZON_RUNS}/composite",
                                  continue_from=f"{LONG_HORIZON_RUNS}/task2/lift_ball")))),
    Study("backbones", "Table II: the method over each shipped prior", tuple(
        (f"prior {prior}", BenchConfig(tasks=list(TABLE1_TASKS), demos=30, methods=["bimanualshift"], prior=prior,
                                       out=f"backbones/{prior}", runs=f"runs/backbones_{prior}"))
        for prior in ("peract_suite_v2", "dp_suite_v2", "rvt_suite"))),
]
# The paper's real platform on the twin (dual UR5e, one front camera): the tasks of Table II built so far, in its
# order (tier by tier), and the priors pretrained on the twin's single-arm skills
REALWORLD_TASKS = ["toasting_completion", "vegetable_sorting", "toaster_activation", "block_threading"]
REALWORLD_PRIOR, REALWORLD_DP_PRIOR = "peract_ur5e_v2", "dp_ur5e"
REALWORLD_METHODS = ["bimanualshift", "peract_lf", "scratch_dp", "no_residual"]
REALWORLD_RUNS = "runs/realworld"
REALWORLD_EPISODES = 30  # test episodes per cell (the paper ran 20 trials); `--episodes` overrides


def _twin(**fields: Any) -> BenchConfig:
    """A benchmark run on the twin: its prior, its demos folder and its episode count unless ``fields`` say."""
    return BenchConfig(**{"prior": REALWORLD_PRIOR, "data": "data/realworld", "episodes": REALWORLD_EPISODES,
                          **fields})


_LONG = f"{REALWORLD_RUNS}/long_horizon"
_STUDIES += [
    Study("realworld", "Table II on the twin: the real-world tasks at 15 demos; BimanualShift over the PerAct-style "
          "and the Diffusion Policy prior, PerAct-LF, Diffusion Policy from scratch and the frozen prior per arm", (
              ("BS-PerAct prior", _twin(tasks=REALWORLD_TASKS, demos=15, methods=REALWORLD_METHODS,
                                        out="realworld/peract", runs=f"{REALWORLD_RUNS}/peract")),
              ("BS-DP prior", _twin(tasks=REALWORLD_TASKS, demos=15, methods=["bimanualshift"],
                                    prior=REALWORLD_DP_PRIOR, out="realworld/dp", runs=f"{REALWORLD_RUNS}/dp")))),
    Study("realworld_generalisation", "Table III on the twin: block threading under the seven perturbations, each "
          "method trained once on unperturbed demos; stage-wise approach / alignment / insertion", (
              ("perturbations", _twin(tasks=["block_threading"], demos=15, methods=["bimanualshift", "peract_lf"],
                                      perturbations=list(PRESETS), out="realworld_generalisation/perturbations",
                                      runs=f"{REALWORLD_RUNS}/peract")),)),
    # the 15-demo half is Table II's cells (its models, settings and seeds): shared, not rolled out again
    Study("realworld_few_shot", "Fig. 11a on the twin: 15 and 5 demos", tuple(
        (f"{n} demos", _twin(tasks=["vegetable_sorting", "block_threading"], demos=n,
                             methods=["bimanualshift", "peract_lf"], out=f"realworld_few_shot/demos_{n}",
                             runs=f"{REALWORLD_RUNS}/{'peract' if n == 15 else f'few_shot_{n}'}",
                             share_from="realworld/peract" if n == 15 else ""))
        for n in (15, 5))),
    Study("realworld_long_horizon", "Fig. 11b on the twin: toasting completion, then toaster activation, each from "
          "the last, then the four-stage insert-press-grasp-place task from 5 demos", (
              ("task 1", _twin(tasks=["toasting_completion"], demos=15, methods=LONG_HORIZON_METHODS,
                               out="realworld_long_horizon/task1", runs=f"{_LONG}/task1")),
              ("task 2", _twin(tasks=["toaster_activation"], demos=15, methods=LONG_HORIZON_METHODS,
                               out="realworld_long_horizon/task2", runs=f"{_LONG}/task2",
                               continue_from=f"{_LONG}/task1/toasting_completion")),
              ("long task", _twin(tasks=["serve_toast"], demos=5, methods=LONG_HORIZON_METHODS,
                                  out="realworld_long_horizon/serve_toast", runs=f"{_LONG}/serve_toast",
                                  continue_from=f"{_LONG}/task2/toaster_activation")))),
]
STUDY_TABLE = {s.name: s for s in _STUDIES}
STUDIES = tuple(STUDY_TABLE)


def study_runs(name: str, root: str = "results") -> list[tuple[str, BenchConfig]]:
    """(label, config) of every benchmark run of a study, its folders under ``root``."""
    if name not in STUDY_TABLE:
        raise ValueError(f"unknown study {name!r}; choose from {STUDIES}")
    return [(label, replace(cfg, out=f"{root}/{cfg.out}", share_from=cfg.share_from and f"{root}/{cfg.share_from}"))
            for label, cfg in STUDY_TABLE[name].runs]


def combined_rows(runs: list[tuple[str, list[dict[str, Any]]]], labelled: bool | None = None
                  ) -> list[dict[str, Any]]:
    """One study's rows from its runs' rows. Runs that share a label form one group (Table I's two halves); each
    group's per-run averages are replaced by one average per method over all of the group's tasks. Rows carry
    their group's label as ``run`` when ``labelled`` (by default: when there is more than one group; a study
    planned with several groups labels its rows however many of them are tabulated)."""
    groups = list(dict.fromkeys(label for label, _ in runs))
    labelled = len(groups) > 1 if labelled is None else labelled
    out = []
    for group in groups:
        rows = [r for label, run_rows in runs if label == group for r in run_rows if r["task"] != "average"]
        if labelled:
            rows = [{**r, "run": group} for r in rows]
        averages = []
        for key in dict.fromkeys((r["method"], r.get("perturbation")) for r in rows):
            mine = [r for r in rows if (r["method"], r.get("perturbation")) == key]
            if len(mine) > 1:
                demos = sorted({r["demos"] for r in mine})
                row = average_row(key[0], demos[0] if len(demos) == 1 else "/".join(map(str, demos)),
                                  [(round(r["success"] * r["episodes"]), r["episodes"]) for r in mine])
                extra = {k: mine[0][k] for k in ("perturbation", "run") if k in mine[0]}
                averages.append({**row, **extra})
        out += rows + averages
    return out


def study_plan(name: str, overrides: dict[str, Any] | None = None, root: str = "results"
               ) -> list[tuple[str, BenchConfig]]:
    """The study's runs with the command line's overrides applied; a ``demos`` override relabels the runs.

    Where the runs split the study's tasks between them (Table I's halves), ``tasks`` selects among them: each
    run keeps the chosen tasks it holds, at its own demos and in its own folder, and a run left with none is
    skipped. Otherwise ``tasks`` replaces every run's tasks."""
    overrides = dict(overrides or {})
    runs = study_runs(name, root)
    chosen = overrides.pop("tasks", None)
    planned_tasks = [t for _, cfg in runs for t in cfg.tasks]
    partition = _partitioned(runs)
    if chosen is not None and partition:
        groups = task_groups()  # built once: it walks every registered task
        unknown = [t for t in chosen if t not in planned_tasks and t not in groups]
        chosen = resolve_task_names(chosen)
        if unknown:
            raise ValueError(f"study {name} has no task {', '.join(unknown)}; its tasks are "
                             f"{', '.join(planned_tasks)}")
    plan = []
    for label, planned in runs:
        if chosen is not None:
            tasks = [t for t in planned.tasks if t in chosen] if partition else list(chosen)
            if not tasks:
                continue
            planned = replace(planned, tasks=tasks)
        cfg = replace(planned, **overrides)
        if cfg.share_from and set(overrides) & {*EPISODE_SETTINGS, *SAME_FOLDERS}:
            cfg = replace(cfg, share_from="")  # other settings than the cells it would share: roll them out here
        plan.append((label.replace(f"{planned.demos} demos", f"{cfg.demos} demos"), cfg))
    return plan


def whole_study_plan(name: str, overrides: dict[str, Any] | None = None, root: str = "results"
                     ) -> list[tuple[str, BenchConfig]]:
    """The plan the study's table covers when a command runs part of it: every run's planned tasks where
    ``--tasks`` picks among Table I's halves, and the study's methods plus any ``--methods`` adds. Its other
    overrides (episodes, demos, results folder) stay, so the table is the same study's."""
    overrides = dict(overrides or {})
    added = overrides.pop("methods", None) or []
    tasks = overrides.pop("tasks", None)
    if tasks is not None and not _partitioned(study_runs(name, root)):
        overrides["tasks"] = tasks  # --tasks replaced the study's tasks: that is the study asked for
    return [(label, replace(cfg, methods=list(dict.fromkeys([*cfg.methods, *added]))))
            for label, cfg in study_plan(name, overrides, root)]


def _partitioned(runs: list[tuple[str, BenchConfig]]) -> bool:
    """Whether the runs split the study's tasks between them (Table I's halves)."""
    planned_tasks = [t for _, cfg in runs for t in cfg.tasks]
    return len(runs) > 1 and len(planned_tasks) == len(set(planned_tasks))



def recorded_plan(plan: list[tuple[str, BenchConfig]]) -> list[tuple[str, BenchConfig]]:
    """The plan narrowed, per group of runs sharing a label, to the methods whose every episode is recorded in
    every run of the group, so that running it trains and rolls out nothing. A method recorded on one of Table I's
    halves only is left out; a group with no such method (a backbone not yet benchmarked) is left out whole."""
    complete: dict[str, set[str]] = {}
    for label, cfg in plan:
        complete.setdefault(label, set(cfg.methods))
        complete[label] &= set(recorded_methods(cfg))
    if not any(complete.values()):
        raise ValueError("no method has every episode of this study recorded yet; run it without --recorded-only")
    return [(label, replace(cfg, methods=[m for m in cfg.methods if m in complete[label]])) for label, cfg in plan
            if complete[label]]


def tabulated_episodes(cfg: BenchConfig) -> list[dict[str, Any]]:
    """The run's episodes that its table counts: its methods and tasks, on its test seeds and perturbations."""
    from bimanualshift.evaluation.bench import bench_seeds, read_episodes

    methods, tasks = set(cfg.methods), set(resolve_task_names(cfg.tasks))
    perturbations, seeds = set(cfg.perturbations), set(bench_seeds(cfg)["test"])
    return [e for e in read_episodes(Path(cfg.out) / "episodes.jsonl")
            if e["method"] in methods and e["task"] in tasks and e["seed"] in seeds
            and e.get("perturbation", "none") in perturbations]


def study_status(name: str, overrides: dict[str, Any] | None = None, root: str = "results"
                 ) -> list[dict[str, Any]]:
    """How much of the study is recorded: per run folder, task and method, the rollouts in its ``episodes.jsonl``
    against those planned. Reads the committed episode logs only, so it works on a fresh clone."""
    return [{"run": label, "out": cfg.out, "task": task, "method": method, "recorded": done, "planned": planned}
            for label, cfg in study_plan(name, overrides, root)
            for (task, method), (done, planned) in recorded_counts(cfg).items()]


def recorded_command(summary: Path, fallback: str) -> str:
    """The command that recorded a result folder's episodes, from its earlier summary (a re-tabulation keeps it,
    so the file still names what produced its numbers), else ``fallback``."""
    if summary.is_file():
        earlier = json.loads(summary.read_text()).get("command", "")
        if earlier and "--recorded-only" not in earlier:
            return earlier
    return fallback


def run_study(name: str, overrides: dict[str, Any] | None = None, root: str = "results",
              recorded_only: bool = False) -> Path:
    """Run (or resume) every run of the study, then its combined table, plots and targets. ``recorded_only``
    tabulates the methods whose episodes are all recorded, and nothing more.

    A command that runs part of the study (``--tasks`` among Table I's halves, ``--methods``) tabulates the whole
    study as ``recorded_only`` would, with what it has just recorded, so the study's tables never shrink to that
    part; while no method is recorded on every task, the part's own table stands."""
    from bimanualshift.evaluation.report import write_result

    started = time.time()
    command = " ".join(["bimanualshift study", *(shlex.quote(a) for a in sys.argv[2:])])
    plan = study_plan(name, overrides, root)
    whole = whole_study_plan(name, overrides, root)
    tabulated = recorded_plan(plan) if recorded_only else plan
    ran: dict[str, Path] = {}  # run folder -> its summary, from this command's part
    begun: dict[str, float] = {}  # run folder -> when this command's part began it (its summary's wall time)
    if whole != plan:
        if not recorded_only:
            for label, cfg in plan:
                begun[cfg.out] = time.time()
                ran[cfg.out] = run_bench(cfg, command=f"{command}  # run: {label}")
        try:
            tabulated, ran = recorded_plan(whole), {}
        except ValueError:
            print(f"[study] {name}: no method is recorded on every task yet; its table shows this command's part")
        else:
            print(f"[study] {name}: tabulating every method recorded on all of its tasks, not this command's part "
                  "alone")
    runs, seeds, configs, episodes = [], {}, [], []
    run_episodes: dict[str, list[dict[str, Any]]] = {}
    for label, cfg in tabulated:
        run_command = f"{command}  # run: {label}"
        if recorded_only:  # nothing is rolled out: the run's summary keeps the command that recorded it
            run_command = recorded_command(Path(cfg.out) / "summary.json", run_command)
        summary = ran.get(cfg.out) or run_bench(cfg, command=run_command, started=begun.get(cfg.out))
        result = json.loads(summary.read_text())
        seeds = {**seeds, **{f"{label} {k}": v for k, v in result["seeds"].items()}}
        runs.append((label, result["rows"]))
        configs.append({"run": label, **asdict(cfg)})
        recorded = tabulated_episodes(cfg)
        run_episodes.setdefault(label, []).extend(recorded)  # runs may share a label (Table I's two halves)
        episodes += recorded
    labelled = len({label for label, _ in plan}) > 1
    rows = combined_rows(runs, labelled=labelled)
    out = Path(root) / name
    out.mkdir(parents=True, exist_ok=True)
    # the full method against every other row on the same scenes: within each run where the study has several
    # (5 and 30 demos, two priors, are not one contest), so there ``paired`` is keyed by the run
    paired = ({label: paired_with_full(eps) for label, eps in run_episodes.items()} if labelled
              else paired_with_full(episodes))
    targets = study_targets(name, rows, paired)
    atomic_write_text(out / "table.md", "\n".join([study_table(name, rows), stage_table(rows),
                                                   targets_table(targets)]))
    draw_plots(out, rows, f"study {name}")
    retabulated = {"tabulated_by": command} if recorded_only else {}
    if recorded_only:
        command = recorded_command(out / "summary.json", command)
    return write_result(out / "summary.json", command, seeds, started, rows, bench=True, study=name, runs=configs,
                        **retabulated,
                        targets=targets, paired=paired,
                        notes="rows carry the run they come from; each run's own folder has its episodes and "
                              "videos; wall time covers this invocation only")
