from __future__ import annotations

from bimanualshift.evaluation.tables import targets_table
from bimanualshift.evaluation.targets import few_shot_targets, table1_targets


def avg(method: str, success: float, run: str | None = None) -> dict:
    row = {"task": "average", "method": method, "success": success, "episodes": 60, "ci95": [0.0, 1.0]}
    return {**row, "run": run} if run else row


def test_table1_targets_compare_the_full_method_with_each_baseline_and_ablation() -> None:
    rows = [avg("bimanualshift", 0.65), avg("scratch_voxel", 0.3), avg("scratch_act", 0.5), avg("anybimanual", 0.6),
            avg("no_projection", 0.7), avg("no_residual", 0.2)]
    targets = {t["target"]: t for t in table1_targets(rows)}
    assert targets["BimanualShift average ≥ 60 %"]["met"] is True
    scratch = targets["≥ 20 points above the best from-scratch baseline"]
    assert scratch["met"] is False and "+15 points vs scratch_act" in scratch["measured"]  # the best, not the first
    assert scratch["measured"].endswith("; scratch_dp not in this run")  # says which were not compared
    assert targets["≥ 10 points above AnyBimanual-style"]["met"] is False
    assert targets["no_projection below the full method"]["met"] is False
    assert targets["no_residual below the full method"]["met"] is True
    assert targets["no_retrieval below the full method"]["met"] is None  # not run: neither met nor missed
    table = targets_table(table1_targets(rows))
    assert "| BimanualShift average ≥ 60 % | 65 % | met |" in table and "**missed**" in table
    assert "not measured" in table


def test_without_the_full_method_nothing_is_claimed() -> None:
    assert [t["met"] for t in table1_targets([avg("scratch_voxel", 0.3)])] == [None]


def test_few_shot_target_compares_5_with_30_demos() -> None:
    rows = [avg("bimanualshift", 0.4, "5 demos"), avg("bimanualshift", 0.6, "30 demos"),
            avg("peract_lf", 0.9, "5 demos")]
    (target,) = few_shot_targets(rows)
    assert target["met"] is False and "40 % vs 0.75 × 60 % = 45 %" in target["measured"]
    (target,) = few_shot_targets([avg("bimanualshift", 0.5, "5 demos"), avg("bimanualshift", 0.6, "30 demos")])
    assert target["met"] is True


def task_row(method: str, task: str, success: float) -> dict:
    return {"task": task, "method": method, "success": success, "episodes": 30, "ci95": [0.0, 1.0]}


def test_table1_targets_against_the_best_baseline_and_on_each_long_task() -> None:
    rows = [avg("bimanualshift", 0.62), avg("peract_lf", 0.68), avg("scratch_voxel", 0.45), avg("no_refinement", 0.5),
            task_row("bimanualshift", "take_tray_out_of_oven", 0.1),
            task_row("scratch_voxel", "take_tray_out_of_oven", 0.3),
            task_row("bimanualshift", "straighten_rope", 0.2), task_row("scratch_voxel", "straighten_rope", 0.1),
            task_row("bimanualshift", "sweep_to_dustpan", 0.0)]
    targets = {t["target"]: t for t in table1_targets(rows)}
    best = targets["≥ the best baseline"]
    assert best["met"] is False and best["measured"].startswith("62 % vs peract_lf 68 %")
    assert "rvt_lf" in best["measured"]  # the baselines not run are named
    assert targets["take tray out of oven > 0 % and ≥ scratch_voxel"]["met"] is False
    assert targets["straighten rope > 0 % and ≥ scratch_voxel"]["met"] is True
    sweep = targets["sweep to dustpan > 0 % and ≥ scratch_voxel"]
    assert sweep["met"] is False and "not in this run" in sweep["measured"]  # 0 % misses whatever the baseline
    assert targets["no_refinement below the full method"]["met"] is True
    assert targets["paper_literal below the full method"]["met"] is None


def test_a_baseline_registered_by_a_plugin_joins_the_best_baseline_target() -> None:
    from dataclasses import replace

    from bimanualshift.registry import METHODS, register_method

    register_method(replace(METHODS["peract_lf"], name="my_lab_baseline", description="a lab's own baseline"))
    try:
        rows = [avg("bimanualshift", 0.62), avg("peract_lf", 0.5), avg("my_lab_baseline", 0.7)]
        best = {t["target"]: t for t in table1_targets(rows)}["≥ the best baseline"]
        assert best["met"] is False and best["measured"].startswith("62 % vs my_lab_baseline 70 %")
    finally:
        del METHODS["my_lab_baseline"]


def test_paired_counts_scenes_each_solved_that_the_other_did_not() -> None:
    from bimanualshift.evaluation.targets import paired_with_full

    def ep(method: str, seed: int, ok: bool, task: str = "t") -> dict:
        return {"task": task, "method": method, "seed": seed, "success": ok}

    episodes = [ep("bimanualshift", s, s < 6) for s in range(8)] + [ep("peract_lf", s, s >= 4) for s in range(8)]
    episodes += [ep("peract_lf", 99, True), ep("no_projection", 0, False, task="other")]  # no partner scene
    paired = paired_with_full(episodes)
    assert paired["peract_lf"] == {"scenes": 8, "full_wins": 4, "method_wins": 2, "p_value": 0.6875}
    assert "no_projection" not in paired  # nothing to pair with
    rows = [avg("bimanualshift", 0.65), avg("peract_lf", 0.64), avg("no_refinement", 0.67)]
    targets = {t["target"]: t for t in table1_targets(rows, {**paired, "no_refinement": {
        "scenes": 600, "full_wins": 22, "method_wins": 31, "p_value": 0.2717}})}
    best = targets["≥ the best baseline"]
    assert best["met"] is True and "65 % vs peract_lf 64 %; paired: 4 to 2 scenes, p = 0.69" in best["measured"]
    assert "paired: 22 to 31 scenes, p = 0.27" in targets["no_refinement below the full method"]["measured"]
    anyb = table1_targets([avg("bimanualshift", 0.65), avg("anybimanual", 0.44)],
                          {"anybimanual": {"scenes": 600, "full_wins": 150, "method_wins": 24, "p_value": 0.0}})
    assert {t["target"]: t for t in anyb}["≥ 10 points above AnyBimanual-style"]["measured"] == (
        "+21 points (44 %); paired: 150 to 24 scenes, p < 0.001")
    assert "paired" not in {t["target"]: t for t in table1_targets(rows)}["≥ the best baseline"]["measured"]
    tiny = table1_targets([avg("bimanualshift", 0.65), avg("no_residual", 0.31)],
                          {"no_residual": {"scenes": 600, "full_wins": 62, "method_wins": 1, "p_value": 0.0}})
    measured = {t["target"]: t["measured"] for t in tiny}["no_residual below the full method"]
    assert "62 to 1 scenes, p < 0.001" in measured


def _realworld_rows() -> list[dict]:
    def row(task: str, method: str, run: str, success: float) -> dict:
        return {"task": task, "method": method, "run": run, "demos": 15, "success": success, "episodes": 30,
                "ci95": [max(0.0, success - 0.15), min(1.0, success + 0.1)]}

    rows = []
    for method, run, rates in (("bimanualshift", "BS-PerAct prior", (0.9, 1.0, 0.8)),
                               ("peract_lf", "BS-PerAct prior", (0.5, 0.6, 0.4)),
                               ("scratch_dp", "BS-PerAct prior", (0.1, 0.2, 0.0)),
                               ("bimanualshift", "BS-DP prior", (0.6, 0.7, 0.5))):
        # the study's order is not the paper's: the tiered table sorts by tier
        for task, rate in zip(("block_threading", "vegetable_sorting", "toaster_activation"), rates):
            rows.append(row(task, method, run, rate))
        rows.append(row("average", method, run, sum(rates) / 3))
    return rows


def test_the_real_world_table_has_table_iis_tiers_and_targets() -> None:
    from bimanualshift.evaluation.tables import table_for

    paired = {"BS-PerAct prior": {"peract_lf": {"scenes": 90, "full_wins": 30, "method_wins": 2, "p_value": 0.0001},
                                  "scratch_dp": {"scenes": 90, "full_wins": 20, "method_wins": 15, "p_value": 0.5}}}
    result = {"command": "bimanualshift study realworld", "commit": "abc123def4567890", "created": "2026",
              "machine": "cpu", "seeds": {}, "wall_time_s": 60.0, "rows": _realworld_rows(), "notes": "n",
              "bench": True, "study": "realworld", "paired": paired}
    lines = table_for(result).splitlines()
    assert lines[0] == ("| tier | task | keyframes | bimanualshift [BS-PerAct prior] | peract_lf [BS-PerAct prior] | "
                        "scratch_dp [BS-PerAct prior] | bimanualshift [BS-DP prior] |")
    assert [line.split(" | ")[1] for line in lines[2:6]] == ["vegetable sorting", "toaster activation",
                                                             "block threading", "average"]
    assert lines[2].startswith("| Coordination | vegetable sorting | 4 | 100 (85–100) | 60 (45–70) |")
    assert lines[4].startswith("| Precision | block threading | 4 |")
    text = "\n".join(lines)
    assert "| bimanualshift [BS-PerAct prior] average ≥ 85.6 % (the paper's) | 90 % | met |" in text
    assert "| bimanualshift [BS-DP prior] average ≥ 65.0 % (the paper's) | 60 % | **missed** |" in text
    assert "above peract_lf, paired p < 0.05 | 90 % vs 50 %; paired: 30 to 2 scenes, p < 0.001 | met |" in text
    assert "above scratch_dp, paired p < 0.05 | 90 % vs 10 %; paired: 20 to 15 scenes, p = 0.5 | **missed** |" in text


def test_the_generalisation_table_has_table_iiis_averages_and_degradations() -> None:
    from bimanualshift.evaluation.tables import table_for

    def row(method: str, perturbation: str, stages: tuple[float, float, float]) -> dict:
        return {"task": "block_threading", "method": method, "perturbation": perturbation, "success": stages[-1],
                "episodes": 30, "ci95": [0.0, 1.0],
                "stages": [{"stage": s, "success": v} for s, v in zip(("approach", "alignment", "insertion"), stages)]}

    rows = [row("bimanualshift", "none", (0.9, 0.6, 0.3)), row("peract_lf", "none", (0.6, 0.3, 0.0)),
            row("bimanualshift", "lighting", (0.9, 0.3, 0.0)), row("peract_lf", "lighting", (0.3, 0.0, 0.0)),
            row("bimanualshift", "glare", (0.3, 0.0, 0.0)), row("peract_lf", "glare", (0.6, 0.3, 0.0))]
    result = {"command": "bimanualshift study realworld_generalisation", "commit": "abc123def4567890",
              "created": "2026", "machine": "cpu", "seeds": {}, "wall_time_s": 60.0, "rows": rows, "notes": "n",
              "bench": True, "study": "realworld_generalisation"}
    text = table_for(result, view="headline")
    lines = text.splitlines()
    assert lines[0].startswith("| condition | bimanualshift average | bimanualshift last stage | bimanualshift RDR |")
    assert lines[2] == "| none | 60.0 | 30 | – | 30.0 | 0 | – |"
    assert lines[3] == "| lighting | 40.0 | 0 | 33 % | 10.0 | 0 | 67 % |"  # (60 - 40) / 60 and (30 - 10) / 30
    assert lines[4] == "| glare | 10.0 | 0 | 83 % | 30.0 | 0 | 0 % |"
    assert "| bimanualshift's stage average above peract_lf's under every condition | 2 of 3; not under glare |" in text
    assert ("| bimanualshift's degradation below peract_lf's under ≥ 5 of the 7 perturbations | 1 of 2 | **missed** |"
            in text)
    assert "stage-wise success" not in text and "stage-wise success" in table_for(result)


def test_fig_11_targets_on_the_twin() -> None:
    from bimanualshift.evaluation.targets import study_targets

    def row(task: str, method: str, run: str, success: float, stages: tuple = ()) -> dict:
        return {"task": task, "method": method, "run": run, "success": success, "ci95": [0, 1], "episodes": 30,
                "stages": [{"stage": n, "success": v} for n, v in stages]}

    few = [row("vegetable_sorting", "bimanualshift", "5 demos", 0.9),
           row("vegetable_sorting", "peract_lf", "5 demos", 0.3),
           row("block_threading", "bimanualshift", "5 demos", 0.6), row("block_threading", "peract_lf", "5 demos", 0.1),
           row("block_threading", "bimanualshift", "15 demos", 0.9)]
    targets = {t["target"].split(" at ")[0]: t for t in study_targets("realworld_few_shot", few)}
    assert targets["vegetable sorting"]["met"] is True
    assert "90 % vs peract_lf 30 %" in targets["vegetable sorting"]["measured"]
    assert targets["block threading"]["met"] is False  # 60 % < the paper's 65 %, though above PerAct-LF
    assert targets["pouring water"]["met"] is None  # not built into the run
    stages = (("insert", 1.0), ("press", 1.0), ("grasp", 0.8), ("place", 0.76))
    long = [row("serve_toast", "bimanualshift", "long task", 0.76, stages),
            row("serve_toast", "no_retrieval", "long task", 0.6, (("insert", 1.0), ("press", 1.0), ("grasp", 0.8),
                                                                 ("place", 0.6)))]
    first, second = study_targets("realworld_long_horizon", long)
    assert first["met"] is True and first["measured"] == "76 %"
    assert second["met"] is False and second["measured"] == "grasp 80 % vs 80 %; place 76 % vs 60 %"
