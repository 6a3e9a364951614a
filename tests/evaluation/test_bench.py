"""The benchmark harness: rows and averages, a real (tiny) resumable run, and the method registry."""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from bimanualshift.evaluation.bench import BenchConfig, bench_rows, read_episodes, recorded_counts, run_bench
from bimanualshift.evaluation.explain import explain_rows
from bimanualshift.evaluation.stats import wilson_interval
from bimanualshift.evaluation.tables import bench_table, stage_table
from bimanualshift.evaluation.viewer import read_recording
from bimanualshift.registry import METHODS, REFINE_FOLDER, get_method


def test_rows_average_tasks_and_pool_intervals() -> None:
    episodes = ([{"task": "a", "method": "m", "seed": s, "success": s < 3} for s in range(4)]
                + [{"task": "b", "method": "m", "seed": s, "success": s < 1} for s in range(4)])
    rows = bench_rows(episodes, ["m"], ["a", "b"], demos=5)
    assert [(r["task"], r["success"]) for r in rows] == [("a", 0.75), ("b", 0.25), ("average", 0.5)]
    assert rows[2]["ci95"] == [round(x, 4) for x in wilson_interval(4, 8)] and rows[2]["episodes"] == 8
    table = bench_table(rows)
    assert table.splitlines()[0] == "| method | a | b | average |" and "| m | 75 (" in table


def test_multi_stage_tasks_report_stage_wise_success() -> None:
    episodes = [{"task": "take_tray_out_of_oven", "method": "m", "seed": s, "success": done == 2, "stages_done": done}
                for s, done in enumerate([0, 1, 1, 2])]
    (row,) = bench_rows(episodes, ["m"], ["take_tray_out_of_oven"], demos=5)
    assert [(s["stage"], s["success"]) for s in row["stages"]] == [("door open", 0.75), ("tray out", 0.25)]
    assert row["stages"][0]["ci95"] == [round(x, 4) for x in wilson_interval(3, 4)]
    assert "| m | 75 | 25 |" in stage_table([row])
    (plain,) = bench_rows([{"task": "lift_ball", "method": "m", "seed": 0, "success": True}], ["m"], ["lift_ball"], 5)
    assert "stages" not in plain and stage_table([plain]) == ""


def test_plots_are_redrawn_from_a_summary_and_stage_lines_only_for_staged_tasks(tmp_path: Path) -> None:
    from bimanualshift.evaluation.plots import redraw_plots

    staged = [{"task": "take_tray_out_of_oven", "method": "m", "seed": s, "success": done == 2, "stages_done": done}
              for s, done in enumerate([0, 1, 2])]
    rows = bench_rows(staged, ["m"], ["take_tray_out_of_oven"], demos=5)
    (tmp_path / "summary.json").write_text(json.dumps({"rows": rows, "study": "x"}))
    drawn = redraw_plots(tmp_path)
    assert [p.name for p in drawn] == ["success.png", "stages.png"]
    assert all(p.read_bytes().startswith(b"\x89PNG") for p in drawn)
    plain = tmp_path / "plain"
    plain.mkdir()
    rows = bench_rows([{"task": "lift_ball", "method": "m", "seed": 0, "success": True}], ["m"], ["lift_ball"], 5)
    (plain / "summary.json").write_text(json.dumps({"rows": rows}))
    assert [p.name for p in redraw_plots(plain)] == ["success.png"]
    with pytest.raises(FileNotFoundError, match="no summary.json"):
        redraw_plots(tmp_path / "nowhere")
    (plain / "summary.json").write_text(json.dumps({"rows": [{"metric": 1}]}))
    with pytest.raises(ValueError, match="not a bench result"):
        redraw_plots(plain)


def test_registry_names_every_ablation_and_refuses_unknown_methods() -> None:
    assert {"bimanualshift", "no_projection", "no_residual", "no_retrieval", "unstructured"} <= set(METHODS)
    with pytest.raises(ValueError, match="unknown method 'act'"):
        get_method("act")


def test_bench_runs_resumes_and_reports(demo_root: Path, tmp_path: Path) -> None:
    from tests.training.test_train_resume import pretrain, pretrain_cfg

    prior = pretrain(pretrain_cfg(demo_root, tmp_path / "prior", steps=2))
    cfg = BenchConfig(tasks=["push_two_buttons"], methods=["bimanualshift", "no_residual"], demos=2,
                      validation_demos=1, episodes=2, prior=str(prior), steps=2, workers=1,
                      data=str(tmp_path / "data"), runs=str(tmp_path / "runs"), out=str(tmp_path / "out"), videos=1,
                      max_keyframes=1, refine_episodes=1, rrd=str(tmp_path / "episodes.rrd"))
    summary = run_bench(cfg, command="test")
    # the video episodes, recorded by the workers as they ran, merged into one recording for the viewer
    seen = read_recording(tmp_path / "episodes.rrd")
    assert {"/".join(e.split("/")[1:4]) for e in seen["entities"]} == {
        "push_two_buttons/bimanualshift/seed_200000", "push_two_buttons/no_residual/seed_200000"}
    assert "/push_two_buttons/no_residual/seed_200000/cameras/front/rgb" in seen["entities"]
    # the full method is refined before it is evaluated: its rollouts and corrections are recorded per task
    refined = json.loads(summary.read_text())["refinement"]
    assert set(refined) == {"push_two_buttons/bimanualshift"} and refined["push_two_buttons/bimanualshift"][
        "scenes"] == 1
    # the residual's training run is summarised beside the table: its checkpoint and validation errors
    trained = json.loads(summary.read_text())["training"]
    assert set(trained) == {"push_two_buttons/bimanualshift"}  # no_residual trains nothing
    assert trained["push_two_buttons/bimanualshift"]["best"]["step"] in (0, 2)
    assert "prior_median_m" in trained["push_two_buttons/bimanualshift"]["validation_translation_error"]
    log = tmp_path / "out" / "episodes.jsonl"
    first = read_episodes(log)
    # every episode's keyframes are logged beside it: executed and expert actions, and the policy's own log
    logged = {(r["method"], r["seed"]): r["steps"] for r in read_episodes(tmp_path / "out" / "keyframes.jsonl")}
    assert set(logged) == {(e["method"], e["seed"]) for e in first}
    for e in first:
        steps = logged[(e["method"], e["seed"])]
        assert len(steps) == e["keyframes"] and np.asarray(steps[0]["executed"]).shape == (2, 9)
        assert np.asarray(steps[0]["expert"]).shape == (2, 9) and steps[-1]["stages_done"] == e["stages_done"]
        assert np.asarray(steps[0]["reached"]).shape == (2, 8)  # the poses the arms ended at
        arms = steps[0]["policy"]["arms"]
        assert [a["arm"] for a in arms] == ["left", "right"] and len(arms[0]["prior"]) == 7
        if e["method"] == "bimanualshift":
            np.testing.assert_allclose([a["final"] for a in arms], np.asarray(steps[0]["executed"])[:, :7],
                                       atol=1e-4)
            assert {"held", "gripper", "residual_cm"} <= set(arms[0])
    rows = {r["method"]: r for r in explain_rows(tmp_path / "out", "push_two_buttons")}
    assert {m: r["failures"] for m, r in rows.items()} == {
        m: sum(not e["success"] for e in first if e["method"] == m) for m in ("bimanualshift", "no_residual")}
    assert sorted((e["method"], e["seed"]) for e in first) == [
        ("bimanualshift", 200000), ("bimanualshift", 200001), ("no_residual", 200000), ("no_residual", 200001)]
    # A run killed mid-write: the last record lost and half a line left behind. Resuming re-runs only that one.
    lines = log.read_text().splitlines()
    log.write_text("\n".join(lines[:-1]) + '\n{"task": "push_two_bu')
    run_bench(cfg, command="test")
    again = read_episodes(log)
    assert len(again) == 4 and sorted(map(json.dumps, again)) == sorted(map(json.dumps, first))
    # --rerun: no_residual is rolled out again, its earlier episodes archived; the other method's stay as they were.
    run_bench(replace(cfg, rerun=["no_residual"]), command="test")
    archives = list((tmp_path / "out" / "superseded").iterdir())
    assert [a.name.split("-")[0] for a in archives] == ["no_residual"]
    assert sorted(map(json.dumps, read_episodes(archives[0] / "episodes.jsonl.gz"))) == sorted(
        json.dumps(e) for e in first if e["method"] == "no_residual")
    rerun = read_episodes(log)
    assert [e for e in rerun if e["method"] == "bimanualshift"] == [e for e in first if e["method"] == "bimanualshift"]
    assert sorted(e["seed"] for e in rerun if e["method"] == "no_residual") == [200000, 200001]
    run_bench(replace(cfg, rerun=["no_residual"]), command="test")  # the same command again resumes the re-run
    assert list((tmp_path / "out" / "superseded").iterdir()) == archives and read_episodes(log) == rerun
    first = rerun
    # Every episode recorded: a rerun on a machine without the run's data or checkpoints trains and collects
    # nothing, and reports the same rows.
    shutil.rmtree(tmp_path / "runs")
    shutil.rmtree(tmp_path / "data")
    run_bench(cfg, command="test")
    assert not (tmp_path / "runs").exists() and not (tmp_path / "data").exists()
    assert sorted(map(json.dumps, read_episodes(log))) == sorted(map(json.dumps, first))
    # Another study planning the same cells from the same runs shares them: copied with their keyframe lines, videos
    # and training records, nothing trained or rolled out (the runs are gone), and the summary says how many.
    shared = replace(cfg, methods=["bimanualshift"], out=str(tmp_path / "shared"), share_from=str(tmp_path / "out"))
    assert recorded_counts(shared) == {("push_two_buttons", "bimanualshift"): (2, 2)}
    result = json.loads(run_bench(shared, command="test").read_text())
    mine = [e for e in first if e["method"] == "bimanualshift"]
    assert read_episodes(tmp_path / "shared" / "episodes.jsonl") == mine and not (tmp_path / "runs").exists()
    assert len(read_episodes(tmp_path / "shared" / "keyframes.jsonl")) == 2
    assert result["shared_from"] == {"folder": str(tmp_path / "out"), "episodes": 2}
    assert set(result["training"]) == {"push_two_buttons/bimanualshift"}
    assert [p.name for p in (tmp_path / "shared" / "videos").iterdir()] == ["push_two_buttons_bimanualshift_200000.mp4"]
    run_bench(shared, command="test")  # sharing again copies nothing twice
    assert read_episodes(tmp_path / "shared" / "episodes.jsonl") == mine
    # cells made from other demos or other runs are not this run's: refused, naming the difference
    with pytest.raises(ValueError, match=r"share_from=.*demos=2 there, 3 here"):
        run_bench(replace(shared, demos=3, out=str(tmp_path / "shared3")), command="test")
    with pytest.raises(ValueError, match=r"share_from=.*runs=.* there, 'elsewhere' here"):
        run_bench(replace(shared, runs="elsewhere", out=str(tmp_path / "shared4")), command="test")
    # The folder's episodes came from 2 demos: a 3-demo run is refused before any work, not silently mixed in.
    with pytest.raises(ValueError, match=r"demos=2 there, 3 now.*own --out"):
        run_bench(replace(cfg, demos=3), command="test")
    # A third episode asked for while the runs behind the first two are gone: a new model would finish another
    # model's rows, so the benchmark stops and says how to go on.
    with pytest.raises(ValueError, match=r"2 test episodes of bimanualshift on push_two_buttons are recorded.*"
                                         r"--rerun push_two_buttons/bimanualshift \(this task\) or --rerun "
                                         r"bimanualshift"):
        run_bench(replace(cfg, episodes=3), command="test")
    assert sorted(map(json.dumps, read_episodes(log))) == sorted(map(json.dumps, first))
    # --episodes 0 trains every method and rolls nothing out.
    train_only = replace(cfg, episodes=0, methods=["bimanualshift"], runs=str(tmp_path / "runs_only"),
                         out=str(tmp_path / "out_only"))
    run_bench(train_only, command="test")
    assert (tmp_path / "runs_only" / "push_two_buttons" / "bimanualshift" / "best" / "config.json").is_file()
    assert not read_episodes(tmp_path / "out_only" / "episodes.jsonl")
    result = json.loads(summary.read_text())
    assert result["bench"] and {r["method"] for r in result["rows"]} == {"bimanualshift", "no_residual"}
    assert result["seeds"]["test"] == [200000, 200001] and result["seeds"]["train"] == [0, 1]
    out = tmp_path / "out"
    assert (out / "success.png").stat().st_size > 0 and (out / "table.md").read_text().startswith("| method |")
    assert sorted(p.name for p in (out / "videos").iterdir()) == [
        "push_two_buttons_bimanualshift_200000.mp4", "push_two_buttons_no_residual_200000.mp4"]


def test_rows_under_perturbations_report_relative_degradation() -> None:
    episodes = ([{"task": "a", "method": "m", "perturbation": "none", "seed": s, "success": s < 4} for s in range(4)]
                + [{"task": "a", "method": "m", "perturbation": "glare", "seed": s, "success": s < 1}
                   for s in range(4)])
    rows = bench_rows(episodes, ["m"], ["a"], demos=5, perturbations=["none", "glare"])
    assert [(r["perturbation"], r["success"]) for r in rows] == [("none", 1.0), ("glare", 0.25)]
    assert rows[1]["degradation"] == 0.75 and "degradation" not in rows[0]
    assert "| m (glare) | 25 (" in bench_table(rows)


def test_a_perturbation_that_helps_is_said_as_a_gain_in_the_stage_table() -> None:
    episodes = ([{"task": "a", "method": "m", "perturbation": "none", "seed": s, "success": s < 2, "stages_done": 0}
                 for s in range(4)]
                + [{"task": "a", "method": "m", "perturbation": "glare", "seed": s, "success": s < 3, "stages_done": 0}
                   for s in range(4)])
    rows = bench_rows(episodes, ["m"], ["a"], demos=5, perturbations=["none", "glare"])
    rows = [{**r, "stages": [{"stage": "done", "success": r["success"]}]} for r in rows]
    assert rows[1]["degradation"] == -0.5
    assert "(50 % above unperturbed)" in stage_table(rows) and "-50 %" not in stage_table(rows)


def test_training_steps_come_from_the_method_unless_the_benchmark_says_otherwise() -> None:
    from bimanualshift.configs import RESIDUAL_STEPS
    from bimanualshift.evaluation.bench import _request
    from bimanualshift.registry import DEFAULT_TRAIN_STEPS

    base = BenchConfig(tasks=["push_two_buttons"])
    assert _request(base, "push_two_buttons", "bimanualshift").steps == RESIDUAL_STEPS
    assert _request(base, "push_two_buttons", "peract_lf").steps == DEFAULT_TRAIN_STEPS
    assert _request(base, "push_two_buttons", "scratch_voxel").steps == 3000  # the benchmark's per-method table
    every = BenchConfig(tasks=["push_two_buttons"], steps=2)
    assert {_request(every, "push_two_buttons", m).steps for m in ("bimanualshift", "peract_lf")} == {2}
    assert _request(every, "push_two_buttons", "scratch_voxel").steps == 3000


def test_a_training_run_is_reused_only_for_the_request_that_started_it(tmp_path: Path) -> None:
    from bimanualshift.evaluation.bench import _request, check_training_run

    cfg = BenchConfig(tasks=["lift_ball"], runs=str(tmp_path / "runs"), data=str(tmp_path / "data"))
    request = _request(cfg, "lift_ball", "scratch_voxel")
    check_training_run(request)
    check_training_run(request)  # the same request resumes
    moved = replace(cfg, data=str(tmp_path / "elsewhere"))
    check_training_run(_request(moved, "lift_ball", "scratch_voxel"))  # data may move
    with pytest.raises(ValueError, match=r"demos=30 there, 100 now.*own --runs"):
        check_training_run(_request(replace(cfg, demos=100), "lift_ball", "scratch_voxel"))
    with pytest.raises(ValueError, match="steps=3000 there, 10 now"):
        check_training_run(_request(replace(cfg, method_steps={"scratch_voxel": 10}), "lift_ball", "scratch_voxel"))


def test_the_unrefined_ablation_shares_the_full_methods_training_run_but_not_its_refinement(tmp_path: Path) -> None:
    from bimanualshift.evaluation.bench import REQUEST_FILE, _request, check_training_run

    cfg = BenchConfig(tasks=["lift_ball"], runs=str(tmp_path / "runs"), data=str(tmp_path / "data"))
    full, unrefined = _request(cfg, "lift_ball", "bimanualshift"), _request(cfg, "lift_ball", "no_refinement")
    assert full.out == unrefined.out == str(tmp_path / "runs" / "lift_ball" / "bimanualshift")
    assert "refine_episodes" in full.overrides and "refine_episodes" not in unrefined.overrides
    check_training_run(full)
    check_training_run(unrefined)  # the same training run: the refinement settings are its own stage's
    refine_request = Path(full.out) / REFINE_FOLDER / REQUEST_FILE
    assert json.loads(refine_request.read_text())["refine_episodes"] == full.overrides["refine_episodes"]
    with pytest.raises(ValueError, match="a refinement run made with other settings.*refine_episodes=20 there, 3"):
        check_training_run(_request(replace(cfg, refine_episodes=3), "lift_ball", "bimanualshift"))
    assert _request(cfg, "lift_ball", "no_retrieval").out.endswith("lift_ball/no_retrieval")


def test_a_results_folder_from_before_the_settings_file_is_checked_against_its_summary(tmp_path: Path) -> None:
    from bimanualshift.evaluation.bench import SETTINGS_FILE, check_results_folder

    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text(json.dumps({"config": {"demos": 30, "max_keyframes": 16}}))
    with pytest.raises(ValueError, match="max_keyframes=16 there, 0 now"):
        check_results_folder(BenchConfig(out=str(out), demos=30, max_keyframes=0))
    check_results_folder(BenchConfig(out=str(out), demos=30, max_keyframes=16))
    assert json.loads((out / SETTINGS_FILE).read_text())["demos"] == 30


def test_an_unknown_executor_is_refused_before_any_training(tmp_path: Path) -> None:
    from bimanualshift.evaluation.bench import BenchConfig, run_bench

    with pytest.raises(ValueError, match="--executor 'rya' is not one of local, ray"):
        run_bench(BenchConfig(tasks=["push_two_buttons"], executor="rya", out=str(tmp_path / "out"),
                              runs=str(tmp_path / "runs"), data=str(tmp_path / "data")))
    assert not (tmp_path / "runs").exists()


def test_every_method_of_the_paper_table_gets_its_own_colour() -> None:
    from bimanualshift.evaluation.plots import label_colours
    from bimanualshift.evaluation.studies import TABLE1_METHODS

    methods = list(TABLE1_METHODS)
    assert len(methods) >= 13
    rows = [{"task": "lift_ball", "method": m} for m in methods]
    colours = label_colours(rows)
    assert len(set(colours.values())) == len(methods)  # (11 methods once shared a 10-colour cycle)
    assert colours["bimanualshift"] == label_colours(rows[::-1])["bimanualshift"]  # stable, whatever the row order


def test_plots_colour_by_method_and_place_perturbations_on_the_axis(tmp_path: Path) -> None:
    from bimanualshift.evaluation.plots import bar_plot, group_label, label_colours, series_label, stage_plot

    rows = [{"task": "take_tray_out_of_oven", "method": m, "perturbation": p, "success": 0.5, "ci95": [0.3, 0.7],
             "stages": [{"stage": "door open", "success": 0.9, "ci95": [0.8, 1.0]}]}
            for p in ("none", "glare", "camera_pose") for m in ("bimanualshift", "peract_lf")]
    assert list(label_colours(rows)) == ["bimanualshift", "peract_lf"]  # two colours, not six
    assert [group_label(r, 1) for r in rows[::2]] == ["none", "glare", "camera pose"]
    assert series_label(rows[2]) == "bimanualshift"
    assert bar_plot(tmp_path / "s.png", rows, "t").stat().st_size > 0
    assert stage_plot(tmp_path / "g.png", rows, "t").stat().st_size > 0
    runs = [{"task": "a", "method": "bimanualshift", "run": f"{n} demos"} for n in (30, 5, 15)]
    assert list(label_colours(runs)) == ["bimanualshift [5 demos]", "bimanualshift [15 demos]",
                                         "bimanualshift [30 demos]"]


def test_a_stage_plots_legend_names_every_method_of_every_panel() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bimanualshift.evaluation.plots import legend_entries

    fig, (first, second) = plt.subplots(1, 2)
    first.plot([0, 1], label="peract_lf")  # the full method has no row on the first panel's task
    second.plot([0, 1], label="bimanualshift")
    second.plot([0, 1], label="peract_lf")
    handles, labels = legend_entries([first, second])
    plt.close(fig)
    assert labels == ["peract_lf", "bimanualshift"] and len(handles) == 2


def test_table1_runs_the_full_method_every_baseline_every_ablation_and_the_frozen_prior() -> None:
    from bimanualshift.evaluation.studies import TABLE1_METHODS
    from bimanualshift.registry import methods_with_role

    assert set(methods_with_role("ablation")) == {"no_projection", "no_residual", "no_retrieval", "no_refinement",
                                                  "unstructured", "paper_literal"}
    assert set(methods_with_role("from_scratch")) == {"scratch_voxel", "scratch_dp", "scratch_act"}
    assert set(methods_with_role("baseline")) == {"peract_lf", "rvt_lf", "dp_lf", "anybimanual", "voxactb"}
    assert TABLE1_METHODS[0] == "bimanualshift" and len(TABLE1_METHODS) == len(set(TABLE1_METHODS)) == 16
    assert "frozen_prior_per_arm" in TABLE1_METHODS and "action_space" not in TABLE1_METHODS  # a variant


def test_a_method_with_an_unknown_role_is_refused() -> None:
    from bimanualshift.registry import register_method

    with pytest.raises(ValueError, match="role 'basline' is not one of method, ablation"):
        register_method(replace(METHODS["peract_lf"], name="peract_lf_typo", role="basline"))
    assert "peract_lf_typo" not in METHODS


def test_refined_methods_are_the_full_method_and_its_ablations_but_no_refinement() -> None:
    refined = {name for name, spec in METHODS.items() if spec.refine}
    assert {"bimanualshift", "no_projection", "no_retrieval", "unstructured", "paper_literal"} <= refined
    assert "no_refinement" not in refined and "no_residual" not in refined and "peract_lf" not in refined


def test_design_choices_roll_out_on_validation_seeds_never_test_seeds(demo_root: Path, tmp_path: Path) -> None:
    from bimanualshift.evaluation.bench import VALIDATION_ROLLOUT_START

    cfg = BenchConfig(tasks=["push_two_buttons"], methods=["no_residual"], demos=1, validation_demos=1, episodes=2,
                      workers=1, data=str(tmp_path / "data"), runs=str(tmp_path / "runs"), out=str(tmp_path / "out"),
                      videos=0, max_keyframes=1, evaluate_on="validation")
    summary = json.loads(run_bench(cfg, command="test").read_text())
    rollouts = [100_000 + VALIDATION_ROLLOUT_START, 100_001 + VALIDATION_ROLLOUT_START]
    assert summary["seeds"]["validation_rollouts"] == rollouts and "test" not in summary["seeds"]
    assert {e["seed"] for e in read_episodes(tmp_path / "out" / "episodes.jsonl")} == set(rollouts)
    with pytest.raises(ValueError, match="evaluate_on"):
        run_bench(replace(cfg, evaluate_on="train", out=str(tmp_path / "other")))


def test_refinement_records_keep_the_fine_tuning_step_refinement_handed_on(tmp_path: Path) -> None:
    from bimanualshift.evaluation.bench import refinement_records

    cfg = BenchConfig(tasks=["lift_ball"], methods=["bimanualshift", "no_refinement"], runs=str(tmp_path))
    summary = {"scenes": 20, "policy_successes": 20, "corrected_successes": 0, "correction_samples": 0,
               "inserted_into_memory": 20, "memory_entries": 118, "best": {"step": 0, "value": 0.1},
               "wall_time_s": 108.8}
    folder = tmp_path / "lift_ball" / "bimanualshift" / REFINE_FOLDER
    folder.mkdir(parents=True)
    (folder / "summary.json").write_text(json.dumps(summary))
    records = refinement_records(cfg, ["lift_ball"])
    assert list(records) == ["lift_ball/bimanualshift"]  # the unrefined ablation has no refinement stage
    assert records["lift_ball/bimanualshift"]["best"] == {"step": 0, "value": 0.1}
    assert "wall_time_s" not in records["lift_ball/bimanualshift"]


def test_records_of_runs_no_longer_on_disk_are_carried_from_the_earlier_summary(tmp_path: Path) -> None:
    from bimanualshift.evaluation.bench import carried_records

    summary = tmp_path / "summary.json"
    assert carried_records(summary, "training", {"t/a": {"best": 1}}, []) == {"t/a": {"best": 1}}  # no summary yet
    summary.write_text(json.dumps({"training": {"t/a": {"best": 0}, "t/b": {"best": 2}, "t/gone": {"best": 3}}}))
    episodes = [{"task": "t", "method": m, "seed": 0} for m in ("a", "b", "c")]
    # a retrained here is read afresh, b's run is gone but its episodes stay, "gone" has no episodes left
    assert carried_records(summary, "training", {"t/a": {"best": 1}}, episodes) == {"t/a": {"best": 1},
                                                                                    "t/b": {"best": 2}}
    assert carried_records(summary, "refinement", {}, episodes) == {}


def test_refined_rows_without_a_refinement_record_are_named() -> None:
    from bimanualshift.evaluation.bench import refinement_missing

    episodes = [{"task": "t", "method": m, "seed": s} for m in ("bimanualshift", "no_refinement", "peract_lf")
                for s in (0, 1)]
    # only the refined method owes a record; the unrefined ablation and the baseline have no refinement stage
    assert refinement_missing({}, episodes) == ["t/bimanualshift"]
    assert refinement_missing({"t/bimanualshift": {"scenes": 20}}, episodes) == []


def test_memory_variants_share_the_full_method_s_training_and_refine_in_folders_of_their_own(tmp_path: Path) -> None:
    from bimanualshift.evaluation.bench import refinement_records

    names = ("bimanualshift", "corrections_memory", "fixed_memory", "validated_refinement")
    specs = [get_method(m) for m in names]
    assert {s.run_name for s in specs} == {"bimanualshift"}
    assert [s.refine_folder for s in specs] == [REFINE_FOLDER, f"{REFINE_FOLDER}_corrected", f"{REFINE_FOLDER}_none",
                                                f"{REFINE_FOLDER}_validated10"]
    for inserted, spec in enumerate(specs):
        folder = tmp_path / "lift_ball" / "bimanualshift" / spec.refine_folder
        folder.mkdir(parents=True)
        (folder / "summary.json").write_text(json.dumps({"scenes": 20, "inserted_into_memory": inserted}))
    records = refinement_records(BenchConfig(tasks=["lift_ball"], methods=list(names), runs=str(tmp_path)),
                                 ["lift_ball"])
    assert {k: r["inserted_into_memory"] for k, r in records.items()} == {
        f"lift_ball/{m}": i for i, m in enumerate(names)}


def test_a_plot_title_names_the_split_its_episodes_come_from() -> None:
    from bimanualshift.evaluation.plots import plot_title

    rows = [{"task": "t", "method": "m", "demos": 30, "episodes": 30}]
    assert plot_title({"rows": rows, "seeds": {"test": [1]}}).startswith("30 demos, 30 test episodes per task")
    assert "30 validation episodes per task" in plot_title(
        {"rows": rows, "seeds": {"train": [0], "validation": [2], "validation_rollouts": [3]}})
    assert plot_title({"rows": rows, "study": "backbones"}) == "study backbones"


def test_a_process_running_two_benchmarks_builds_each_ones_frozen_prior(tmp_path: Path,
                                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """Episodes of the checkpoint-less frozen prior run in one process for two priors: each gets its own policy
    (the process cache once handed the first prior's policy to the second benchmark)."""
    import bimanualshift.evaluation.bench as bench_module
    from bimanualshift.evaluation.bench import BenchJob, run_bench_episode

    built: list[str] = []
    real = get_method("frozen_prior_per_arm")

    def load(checkpoint, request):  # noqa: ANN001, ANN202
        built.append(request.prior)
        return real.load(checkpoint, request)

    monkeypatch.setattr(bench_module, "get_method", lambda name: replace(real, load=load))
    for prior in ("peract_suite", "peract_suite_v2", "peract_suite"):
        request = {"task": "push_two_buttons", "data": "", "validation_data": "", "demos": 1, "prior": prior,
                   "out": str(tmp_path), "steps": 1}
        run_bench_episode(BenchJob("frozen_prior_per_arm", "push_two_buttons", 200_000, "", request,
                                   max_keyframes=1))
    assert built == ["peract_suite", "peract_suite_v2"]  # the third episode reuses the first prior's policy
