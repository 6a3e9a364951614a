"""The studies are named lists of benchmark runs with disjoint run folders."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from bimanualshift.evaluation.studies import STUDIES, combined_rows, study_plan, study_runs
from bimanualshift.evaluation.tables import bench_table
from bimanualshift.registry import METHODS
from bimanualshift.sim.perturbations import PRESETS
from bimanualshift.sim.task_registry import resolve_task_names


@pytest.mark.parametrize("name", STUDIES)
def test_every_study_names_known_tasks_methods_and_separate_folders(name: str) -> None:
    runs = study_runs(name, root="/tmp/r")
    assert runs and len({cfg.out for _, cfg in runs}) == len(runs)
    assert len({(cfg.runs, cfg.demos, cfg.prior) for _, cfg in runs}) == len(runs)  # no run reuses another's models
    for _, cfg in runs:
        assert set(cfg.methods) <= set(METHODS)
        resolve_task_names(cfg.tasks)
        assert set(cfg.perturbations) <= set(PRESETS)


def test_few_shot_and_table1_follow_the_paper() -> None:
    assert [cfg.demos for _, cfg in study_runs("few_shot")] == [5, 15, 30]
    table1 = [cfg for _, cfg in study_runs("table1")]
    assert table1[0].tasks == ["take_tray_out_of_oven", "straighten_rope", "sweep_to_dustpan"]
    assert table1[0].demos == 30 and table1[1].demos == 100
    assert len(study_runs("generalisation")[0][1].perturbations) == len(PRESETS)
    backbones = study_runs("backbones")
    assert [cfg.prior for _, cfg in backbones] == ["peract_suite_v2", "dp_suite_v2", "rvt_suite"]
    assert all(cfg.tasks == table1[0].tasks + table1[1].tasks for _, cfg in backbones)  # Table II: the six tasks
    with pytest.raises(ValueError, match="unknown study"):
        study_runs("ablations")


def test_overrides_apply_to_every_run_and_a_demos_override_relabels() -> None:
    plan = study_plan("table1", {"demos": 30, "episodes": 10})
    assert all(cfg.demos == 30 and cfg.episodes == 10 for _, cfg in plan)
    assert plan[1][1].tasks == ["lift_ball", "push_two_buttons", "pick_up_plate"]
    assert [label for label, _ in study_plan("few_shot", {"episodes": 5})] == ["5 demos", "15 demos", "30 demos"]


def test_tasks_select_within_table1_halves_and_replace_elsewhere() -> None:
    plan = study_plan("table1", {"tasks": ["push_two_buttons", "sweep_to_dustpan"], "episodes": 30})
    assert [(cfg.tasks, cfg.demos, cfg.out) for _, cfg in plan] == [
        (["sweep_to_dustpan"], 30, "results/table1/complex_tasks"),
        (["push_two_buttons"], 100, "results/table1/simpler_tasks")]
    only_simple = study_plan("table1", {"tasks": ["lift_ball"]})
    assert [cfg.out for _, cfg in only_simple] == ["results/table1/simpler_tasks"]
    with pytest.raises(ValueError, match="no task pick_cube"):
        study_plan("table1", {"tasks": ["pick_cube"]})  # a single-arm task: in no half
    with pytest.raises(ValueError, match="lift_bal"):
        study_plan("table1", {"tasks": ["lift_bal"]})
    assert sum(len(cfg.tasks) for _, cfg in study_plan("table1", {"tasks": ["bimanual"]})) == 6
    # a study whose runs share their tasks (few-shot: the same tasks at 5/15/30 demos) takes them as given
    assert all(cfg.tasks == ["lift_ball"] for _, cfg in study_plan("few_shot", {"tasks": ["lift_ball"]}))


def test_table1_halves_form_one_row_per_method_with_one_average_over_six_tasks() -> None:
    def run(tasks: list[str], demos: int, successes: list[int]) -> list[dict]:
        rows = [{"task": t, "method": "m", "demos": demos, "success": k / 10, "episodes": 10, "ci95": [0.0, 1.0]}
                for t, k in zip(tasks, successes)]
        return rows + [{"task": "average", "method": "m", "demos": demos, "success": 0.0, "episodes": 30,
                        "ci95": [0.0, 1.0]}]

    rows = combined_rows([("all tasks", run(["a", "b", "c"], 30, [0, 1, 2])),
                          ("all tasks", run(["d", "e", "f"], 100, [3, 4, 8]))])
    assert [r["task"] for r in rows] == ["a", "b", "c", "d", "e", "f", "average"]
    average = rows[-1]
    assert average["success"] == pytest.approx(0.3) and average["episodes"] == 60 and average["demos"] == "30/100"
    assert "run" not in average  # one group: the rows need no run label
    table = bench_table(rows)
    assert table.splitlines()[0].endswith("| f | average |") and "| m | 0 (" in table and "| 30 (" in table
    grouped = combined_rows([("5 demos", run(["a", "b"], 5, [1, 1])), ("30 demos", run(["a", "b"], 30, [5, 7]))])
    assert [(r["run"], r["task"]) for r in grouped if r["task"] == "average"] == [("5 demos", "average"),
                                                                                ("30 demos", "average")]
    assert grouped[-1]["success"] == pytest.approx(0.6)


def test_combined_table_keeps_runs_apart() -> None:
    rows = [{"task": "a", "method": "m", "run": run, "success": s, "ci95": [0.0, 1.0]}
            for run, s in (("5 demos", 0.2), ("30 demos", 0.6))]
    table = bench_table(rows)
    assert "| m [5 demos] | 20 (" in table and "| m [30 demos] | 60 (" in table


def test_long_horizon_continues_each_task_from_the_one_before(tmp_path: object) -> None:
    from pathlib import Path

    from bimanualshift.evaluation.bench import _request

    runs = [cfg for _, cfg in study_runs("long_horizon")]
    assert [cfg.tasks for cfg in runs] == [["push_two_buttons"], ["lift_ball"], ["buttons_then_lift_ball"]]
    assert runs[1].continue_from == f"{runs[0].runs}/push_two_buttons"
    assert runs[2].continue_from == f"{runs[1].runs}/lift_ball" and runs[2].demos == 5
    assert set(runs[2].methods) == {"bimanualshift", "no_retrieval", "peract_lf"}
    # Each continual method starts from its own earlier run; one that is missing is a clear error.
    earlier = Path(str(tmp_path)) / "runs" / "lift_ball"
    (earlier / "bimanualshift").mkdir(parents=True)
    cfg = replace(runs[2], continue_from=str(earlier))
    assert _request(cfg, "buttons_then_lift_ball", "bimanualshift").overrides == {
        "init_from": str(earlier / "bimanualshift"), "refine_episodes": cfg.refine_episodes}
    assert _request(cfg, "buttons_then_lift_ball", "no_residual").overrides == {}  # trains nothing
    with pytest.raises(FileNotFoundError, match="peract_lf has no earlier run"):
        _request(cfg, "buttons_then_lift_ball", "peract_lf")


def _record_table1(root: Path, recorded: dict[str, tuple[str, ...]], seeds: list[int]) -> None:
    """Write Table I's two halves' episode logs: every seed of each method's tasks, the first seed a success."""
    import json

    from bimanualshift.evaluation.studies import TABLE1_TASKS

    for half, tasks in (("complex_tasks", TABLE1_TASKS[:3]), ("simpler_tasks", TABLE1_TASKS[3:])):
        folder = root / "results" / "table1" / half
        folder.mkdir(parents=True, exist_ok=True)
        lines = [{"task": t, "method": m, "seed": s, "success": s == seeds[0], "keyframes": 3}
                 for m, done in recorded.items() for t in tasks if t in done for s in seeds]
        (folder / "episodes.jsonl").write_text("".join(json.dumps(e) + "\n" for e in lines))


def test_recorded_only_tabulates_the_methods_recorded_on_every_task_and_runs_nothing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import json

    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.studies import TABLE1_TASKS, run_study

    monkeypatch.chdir(tmp_path)  # the study's runs/ and data/ are relative: nothing may appear there
    # peract_lf: the long tasks only
    _record_table1(tmp_path, {"bimanualshift": TABLE1_TASKS, "peract_lf": TABLE1_TASKS[:3]}, split_seeds("test", 2))
    summary = json.loads(run_study("table1", {"episodes": 2, "videos": 0}, "results", recorded_only=True).read_text())
    averages = {r["method"]: r for r in summary["rows"] if r["task"] == "average"}
    assert set(averages) == {"bimanualshift"} and averages["bimanualshift"]["success"] == 0.5
    assert {r["task"] for r in summary["rows"] if r["method"] == "bimanualshift"} == {*TABLE1_TASKS, "average"}
    assert not (tmp_path / "runs").exists() and not (tmp_path / "data").exists()
    with pytest.raises(ValueError, match="no method has every episode"):
        run_study("table1", {"episodes": 3, "videos": 0}, "elsewhere", recorded_only=True)


def test_recorded_only_leaves_out_a_study_run_not_yet_recorded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import json

    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.studies import TABLE1_TASKS, run_study

    monkeypatch.chdir(tmp_path)
    seeds = split_seeds("test", 2)
    folder = tmp_path / "results" / "backbones" / "rvt_suite"  # one of three priors benchmarked
    folder.mkdir(parents=True)
    (folder / "episodes.jsonl").write_text("".join(
        json.dumps({"task": t, "method": "bimanualshift", "seed": s, "success": True, "keyframes": 3}) + "\n"
        for t in TABLE1_TASKS for s in seeds))
    summary = json.loads(run_study("backbones", {"episodes": 2, "videos": 0}, "results", recorded_only=True
                                   ).read_text())
    assert {r["run"] for r in summary["rows"]} == {"prior rvt_suite"}
    assert [r["success"] for r in summary["rows"] if r["task"] == "average"] == [1.0]
    assert not (tmp_path / "runs").exists() and not (tmp_path / "data").exists()


def test_status_counts_recorded_rollouts_per_task_and_method_and_writes_nothing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from bimanualshift.cli import main
    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.studies import TABLE1_TASKS, study_status

    monkeypatch.chdir(tmp_path)
    seeds = split_seeds("test", 3)
    folder = tmp_path / "results" / "table1" / "complex_tasks"
    folder.mkdir(parents=True)
    lines = [{"task": TABLE1_TASKS[0], "method": "peract_lf", "seed": s, "success": True} for s in seeds[:2]]
    lines.append({"task": TABLE1_TASKS[0], "method": "peract_lf", "seed": 999, "success": True})  # not a planned seed
    (folder / "episodes.jsonl").write_text("".join(json.dumps(e) + "\n" for e in lines))
    rows = study_status("table1", {"episodes": 3, "methods": ["bimanualshift", "peract_lf"]})
    cells = {(r["task"], r["method"]): (r["recorded"], r["planned"]) for r in rows}
    assert len(rows) == 12 and cells[(TABLE1_TASKS[0], "peract_lf")] == (2, 3)
    assert cells[(TABLE1_TASKS[0], "bimanualshift")] == (0, 3) and cells[(TABLE1_TASKS[4], "peract_lf")] == (0, 3)
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    main(["study", "table1", "--status", "--episodes", "3", "--methods", "bimanualshift", "peract_lf"])
    assert "2 of 36 rollouts recorded" in capsys.readouterr().out
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before  # nothing trained or written


def test_table1_pairs_the_full_method_with_each_row_on_the_tabulated_scenes(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import json

    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.studies import TABLE1_TASKS, run_study

    monkeypatch.chdir(tmp_path)
    seeds = split_seeds("test", 2)
    for half, tasks in (("complex_tasks", TABLE1_TASKS[:3]), ("simpler_tasks", TABLE1_TASKS[3:])):
        folder = tmp_path / "results" / "table1" / half
        folder.mkdir(parents=True)
        # the full method solves every first seed, peract_lf every second one; a seed beyond the table is ignored
        lines = [{"task": t, "method": m, "seed": s, "success": (s == seeds[0]) == (m == "bimanualshift"),
                  "keyframes": 3} for m in ("bimanualshift", "peract_lf") for t in tasks for s in [*seeds, 7]]
        (folder / "episodes.jsonl").write_text("".join(json.dumps(e) + "\n" for e in lines))
    summary = json.loads(run_study("table1", {"episodes": 2, "videos": 0}, "results", recorded_only=True).read_text())
    assert summary["paired"] == {"peract_lf": {"scenes": 12, "full_wins": 6, "method_wins": 6, "p_value": 1.0}}
    best = next(t for t in summary["targets"] if t["target"] == "≥ the best baseline")
    assert "paired: 6 to 6 scenes, p = 1" in best["measured"]


def test_a_command_running_part_of_table1_tabulates_every_recorded_task_and_method(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import json

    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.studies import TABLE1_TASKS, run_study

    monkeypatch.chdir(tmp_path)
    _record_table1(tmp_path, {"bimanualshift": TABLE1_TASKS, "peract_lf": TABLE1_TASKS}, split_seeds("test", 2))
    part = {"episodes": 2, "videos": 0, "tasks": ["lift_ball"], "methods": ["peract_lf"]}
    summary = json.loads(run_study("table1", part, "results").read_text())
    assert {(r["task"], r["method"]) for r in summary["rows"]} == {
        (t, m) for t in (*TABLE1_TASKS, "average") for m in ("bimanualshift", "peract_lf")}
    assert summary["paired"]["peract_lf"]["scenes"] == 12  # the whole table's scenes, not lift ball's 2
    for half, tasks in (("complex_tasks", TABLE1_TASKS[:3]), ("simpler_tasks", TABLE1_TASKS[3:])):
        rows = json.loads((tmp_path / "results" / "table1" / half / "summary.json").read_text())["rows"]
        assert {r["task"] for r in rows} == {*tasks, "average"}  # the other half too, not lift ball alone
    assert "push two buttons" in (tmp_path / "results" / "table1" / "simpler_tasks" / "table.md").read_text()
    assert not (tmp_path / "runs").exists() and not (tmp_path / "data").exists()


def test_a_part_of_table1_keeps_its_own_table_while_no_method_is_recorded_on_every_task(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import json

    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.studies import run_study

    monkeypatch.chdir(tmp_path)
    _record_table1(tmp_path, {"peract_lf": ("lift_ball",)}, split_seeds("test", 2))
    part = {"episodes": 2, "videos": 0, "tasks": ["lift_ball"], "methods": ["peract_lf"]}
    summary = json.loads(run_study("table1", part, "results").read_text())
    assert [(r["task"], r["method"], r["success"]) for r in summary["rows"]] == [("lift_ball", "peract_lf", 0.5)]


def test_the_whole_study_keeps_every_planned_task_and_method_and_adds_a_method_the_command_names() -> None:
    from bimanualshift.evaluation.studies import TABLE1_METHODS, TABLE1_TASKS, whole_study_plan

    part = {"episodes": 100, "tasks": ["lift_ball"], "methods": ["augment_32", "peract_lf"]}
    whole = whole_study_plan("table1", part, "results")
    assert [cfg.tasks for _, cfg in whole] == [list(TABLE1_TASKS[:3]), list(TABLE1_TASKS[3:])]
    assert all(cfg.methods == [*TABLE1_METHODS, "augment_32"] and cfg.episodes == 100 for _, cfg in whole)
    # where --tasks replaces a study's tasks (no halves), the study asked for is that one
    few_shot = whole_study_plan("few_shot", {"tasks": ["lift_ball"]}, "results")
    assert all(cfg.tasks == ["lift_ball"] for _, cfg in few_shot)


def test_the_realworld_studies_follow_the_papers_real_platform() -> None:
    from bimanualshift.sim.task_registry import task_class

    table2 = study_runs("realworld")
    assert [cfg.prior for _, cfg in table2] == ["peract_ur5e_v2", "dp_ur5e"]
    assert all(cfg.demos == 15 for _, cfg in table2)
    for task in table2[0][1].tasks:  # the twin's tasks, each with the tier and keyframes of its Table II row
        cls = task_class(task)
        assert cls.robot == "ur5e" and cls.tier and cls.paper_keyframes
    generalisation = study_runs("realworld_generalisation")[0][1]
    assert generalisation.tasks == ["block_threading"] and len(generalisation.perturbations) == len(PRESETS)
    # trained once: Table III and the 15-demo few-shot cell reuse Table II's BS-PerAct models
    assert generalisation.runs == table2[0][1].runs == study_runs("realworld_few_shot")[0][1].runs
    assert [cfg.demos for _, cfg in study_runs("realworld_few_shot")] == [15, 5]
    # its 15-demo cells are Table II's, shared from Table II's folder under the same results root; a study run
    # under other settings (--demos) rolls them out itself
    few = study_plan("realworld_few_shot", {}, "elsewhere")
    assert [cfg.share_from for _, cfg in few] == ["elsewhere/realworld/peract", ""]
    assert set(few[0][1].tasks) <= set(table2[0][1].tasks) and set(few[0][1].methods) <= set(table2[0][1].methods)
    assert [cfg.share_from for _, cfg in study_plan("realworld_few_shot", {"demos": 10})] == ["", ""]
    assert study_plan("realworld_few_shot", {"episodes": 10})[0][1].share_from == "results/realworld/peract"
    long = [cfg for _, cfg in study_runs("realworld_long_horizon")]
    assert [c.tasks for c in long] == [["toasting_completion"], ["toaster_activation"], ["serve_toast"]]
    assert long[2].demos == 5 and long[1].continue_from.startswith(long[0].runs)


def test_a_retabulation_keeps_the_command_that_recorded_the_episodes(tmp_path: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    import json
    import sys

    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.studies import TABLE1_TASKS, run_study

    monkeypatch.chdir(tmp_path)
    _record_table1(tmp_path, {"bimanualshift": TABLE1_TASKS}, split_seeds("test", 2))
    recorded = "bimanualshift study table1 --workers 2"
    for half in ("complex_tasks", "simpler_tasks"):
        (tmp_path / "results" / "table1" / half / "summary.json").write_text(json.dumps({"command": recorded}))
    (tmp_path / "results" / "table1" / "summary.json").write_text(json.dumps({"command": recorded}))
    monkeypatch.setattr(sys, "argv", ["bimanualshift", "study", "table1", "--recorded-only"])
    summary = json.loads(run_study("table1", {"episodes": 2, "videos": 0}, "results", recorded_only=True).read_text())
    assert summary["command"] == recorded
    assert summary["tabulated_by"] == "bimanualshift study table1 --recorded-only"
    for half in ("complex_tasks", "simpler_tasks"):
        assert json.loads((tmp_path / "results" / "table1" / half / "summary.json").read_text())["command"] == recorded
