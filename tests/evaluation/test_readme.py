import json
from pathlib import Path

from bimanualshift.evaluation.readme import render_readme


def test_results_block_is_generated_from_the_result_file(tmp_path: Path) -> None:
    (tmp_path / "results" / "demo").mkdir(parents=True)
    (tmp_path / "results" / "demo" / "summary.json").write_text(json.dumps({
        "command": "bimanualshift demo", "commit": "abc123def4567890", "created": "2026-01-01T00:00:00+00:00",
        "machine": "cpu", "seeds": {"test": [200000, 200019]}, "wall_time_s": 600.0,
        "rows": [{"task": "push_two_buttons", "method": "bimanualshift", "demos": 20, "success": 0.55,
                  "episodes": 20, "ci95": [0.342, 0.742]}],
    }))
    readme = tmp_path / "README.md"
    readme.write_text("intro\n<!-- results:demo -->\nstale\n<!-- /results:demo -->\nend\n")
    assert render_readme(readme, tmp_path / "results") == ["demo"]
    text = readme.read_text()
    assert "| push_two_buttons | bimanualshift | 20 | 55.0 % | 34.2–74.2 % | 20 |" in text
    assert "stale" not in text and text.startswith("intro\n") and text.endswith("end\n")
    assert "`bimanualshift demo`" in text and "abc123def456" in text


def test_expert_results_get_their_own_table(tmp_path) -> None:  # noqa: ANN001
    import json

    from bimanualshift.evaluation.readme import render_readme

    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "experts.json").write_text(json.dumps({
        "command": "bimanualshift experts", "commit": "abc", "created": "now", "machine": "m", "wall_time_s": 60,
        "notes": "n", "seeds": {"test": [1]},
        "rows": [{"task": "lift_ball", "bimanual": True, "success": 0.97, "ci95": [0.9, 0.99], "episodes": 100,
                  "mean_wall_time_s": 3.21, "mean_keyframes": 4.0}],
    }))
    readme = tmp_path / "README.md"
    readme.write_text("x\n<!-- results:experts -->\n<!-- /results:experts -->\n")
    assert render_readme(readme, tmp_path / "results") == ["experts"]
    assert "| lift_ball | two | 97.0 % | 90.0–99.0 % | 100 | 3.2 | 4.0 |" in readme.read_text()


def test_other_results_get_a_table_of_their_scalar_fields() -> None:
    from bimanualshift.evaluation.tables import table_for

    table = table_for({
        "command": "python benchmarks/collection_speed.py", "commit": "abcdef0123456789", "created": "now",
        "machine": "m", "wall_time_s": 120, "notes": "n", "seeds": {"train": [0]},
        "rows": [{"task": "lift_ball", "workers": 1, "episodes_per_min": 6.25, "extra": {"ignored": 1}},
                 {"task": "lift_ball", "workers": 2, "episodes_per_min": 11.5, "extra": {"ignored": 1}}],
    })
    lines = table.splitlines()
    assert lines[0] == "| task | workers | episodes per min |"
    assert lines[2:4] == ["| lift_ball | 1 | 6.25 |", "| lift_ball | 2 | 11.5 |"]
    assert "`python benchmarks/collection_speed.py` at commit `abcdef012345`" in table


META = {"command": "bimanualshift x", "commit": "abcdef0123456789", "created": "now", "machine": "m",
        "wall_time_s": 60, "notes": "n", "seeds": {"test": [200000]}}


def test_projection_quality_puts_both_arms_on_one_line() -> None:
    from bimanualshift.evaluation.tables import table_for

    rows = [{"task": "lift_ball", "segmenter": s, "arm": a, "kept": k, "removed": r, "episodes": 50, "keyframes": 400}
            for s, a, k, r in [("simulator", "left", 0.991, 0.97), ("simulator", "right", 0.993, 0.965),
                               ("degraded-mild", "left", 0.9, 0.8), ("degraded-mild", "right", 0.91, 0.81)]]
    lines = table_for({**META, "rows": rows}).splitlines()
    assert lines[2] == "| lift_ball | simulator | 0.991 | 0.970 | 0.993 | 0.965 | 50 | 400 |"
    assert lines[3].startswith("| lift_ball | degraded-mild | 0.900 | 0.800 | 0.910 | 0.810 |")


def test_priors_table_has_one_column_per_prior() -> None:
    from bimanualshift.evaluation.tables import table_for

    def row(name: str, p: float) -> dict:
        return {"prior": name, "type": "peract", "mean_success": p, "parameters": 1234567,
                "inference_ms_per_arm": 12.5, "training_time_s": 1800.0,
                "tasks": {"push_button": {"success": p, "ci95": [p - 0.1, p + 0.05], "episodes": 50}}}

    table = table_for({**META, "rows": [row("peract_unimanual", 0.8), row("dp_unimanual", 0.7)]})
    lines = table.splitlines()
    assert lines[0] == "| task | peract_unimanual | dp_unimanual |"
    assert lines[2] == "| push_button | 80 % (70–85) | 70 % (60–75) |"
    assert "| parameters | 1,234,567 | 1,234,567 |" in lines and "| training time | 30 min | 30 min |" in lines
    assert "50 test episodes per task" in table


def test_index_lists_every_result_file_including_study_runs(tmp_path: Path) -> None:
    from bimanualshift.evaluation.readme import render_index

    envelope = {"command": "c", "commit": "abcdef1234567", "created": "t", "machine": "m", "seeds": {"test": [1]},
                "wall_time_s": 60.0, "notes": "n"}
    (tmp_path / "few_shot" / "demos_5").mkdir(parents=True)
    (tmp_path / "speed.json").write_text(json.dumps({**envelope, "rows": [{"what": "x", "value": 1.5}]}))
    (tmp_path / "few_shot" / "demos_5" / "summary.json").write_text(json.dumps(
        {**envelope, "bench": True, "rows": [{"task": "a", "method": "m", "success": 0.5, "ci95": [0.1, 0.9]}]}))
    index = render_index(tmp_path).read_text()
    assert "## few_shot/demos_5" in index and "## speed" in index
    assert "| m | 50 (10–90) |" in index and "| x | 1.5 |" in index
    assert render_readme(tmp_path / "README.md", tmp_path) == ["few_shot/demos_5", "speed"]  # blocks stay live


def test_index_marks_a_partial_summary(tmp_path: Path, monkeypatch) -> None:
    from bimanualshift.evaluation import readme
    from bimanualshift.evaluation.readme import render_index, unsummarised_pairs

    envelope = {"command": "c", "commit": "abcdef1234567", "created": "t", "machine": "m", "seeds": {"test": [1]},
                "wall_time_s": 60.0, "notes": "n", "bench": True}
    half = tmp_path / "table1" / "complex_tasks"
    half.mkdir(parents=True)
    episodes = [{"task": t, "method": m, "seed": 1, "success": True} for t in ("a", "b") for m in ("x", "y")]
    (half / "episodes.jsonl").write_text("".join(json.dumps(e) + "\n" for e in episodes))
    row = {"task": "a", "method": "x", "success": 0.5, "ci95": [0.1, 0.9]}
    (half / "summary.json").write_text(json.dumps({**envelope, "rows": [row]}))  # the last run covered a/x only
    (tmp_path / "table1" / "summary.json").write_text(json.dumps({**envelope, "rows": [row]}))  # the study's
    assert unsummarised_pairs(half / "summary.json", {"rows": [row]}) == [("a", "y"), ("b", "x"), ("b", "y")]
    reads: list[Path] = []
    read = readme.read_records
    monkeypatch.setattr(readme, "read_records", lambda log: reads.append(log) or read(log))
    index = render_index(tmp_path).read_text()
    assert index.count("**Partial**: 3 task/method pairs") == 2 and "a/y, b/x, b/y" in index
    assert reads.count(half / "episodes.jsonl") == 1  # the study's summary and its half's share one reading
    rows = [{**row, "task": t, "method": m} for t in ("a", "b") for m in ("x", "y")]
    (half / "summary.json").write_text(json.dumps({**envelope, "rows": rows}))
    (tmp_path / "table1" / "summary.json").write_text(json.dumps({**envelope, "rows": rows}))
    index = render_index(tmp_path).read_text()
    assert "Partial" not in index and "<!-- results:table1/complex_tasks -->" in index


def test_index_of_a_missing_results_folder_is_refused(tmp_path: Path) -> None:
    import pytest

    from bimanualshift.evaluation.readme import render_index

    with pytest.raises(FileNotFoundError, match="no results folder"):
        render_index(tmp_path / "nope")
    assert not (tmp_path / "nope").exists()  # nothing written


def test_generic_table_gives_every_rows_fields_a_column() -> None:
    from bimanualshift.evaluation.tables import generic_table

    result = {"rows": [{"what": "train", "seconds": 714.6}, {"what": "eval", "episodes_per_min": 5.0}],
              "command": "c", "commit": "0" * 40, "created": "t", "machine": "m", "wall_time_s": 60, "notes": "n"}
    lines = generic_table(result).splitlines()
    assert lines[0] == "| what | seconds | episodes per min |"
    assert lines[2] == "| train | 714.6 |  |" and lines[3] == "| eval |  | 5 |"
    result["rows"].append({"what": "none", "seconds": None})  # a field not measured for this row
    assert generic_table(result).splitlines()[4] == "| none | – |  |"


def test_a_study_table_carries_its_targets_checked_on_its_rows() -> None:
    from bimanualshift.evaluation.tables import table_for

    rows = [{"task": t, "method": m, "demos": 30, "success": s, "episodes": 10, "ci95": [0.0, 1.0]}
            for m, s in (("bimanualshift", 0.2), ("no_residual", 0.4)) for t in ("a", "average")]
    result = {"command": "bimanualshift study table1", "commit": "abc123def4567890", "created": "2026",
              "machine": "cpu", "seeds": {}, "wall_time_s": 60.0, "rows": rows, "notes": "n", "bench": True,
              "study": "table1"}
    text = table_for(result)
    assert "| BimanualShift average ≥ 60 % | 20 % | **missed** |" in text
    assert "| no_residual below the full method | 40 % vs 20 % | **missed** |" in text
    assert "target" not in table_for({**result, "study": "generalisation"})


def test_report_regenerates_every_document_holding_a_results_block(tmp_path: Path) -> None:
    from bimanualshift.evaluation.readme import results_documents

    (tmp_path / "docs").mkdir()
    block = "<!-- results:x -->\nold\n<!-- /results:x -->\n"
    (tmp_path / "README.md").write_text("# r\n" + block)
    (tmp_path / "docs" / "a.md").write_text(block)
    (tmp_path / "docs" / "b.md").write_text("no block here\n")
    assert results_documents(tmp_path) == [str(tmp_path / "README.md"), str(tmp_path / "docs" / "a.md")]
    assert str(Path("docs") / "residual.md") in results_documents()  # the project's own docs are found


def test_a_headline_view_leaves_the_stage_tables_out(tmp_path: Path) -> None:
    import pytest

    from bimanualshift.evaluation.tables import table_for

    stages = [{"stage": "door open", "success": 1.0}, {"stage": "tray out", "success": 0.5}]
    rows = [{"task": "take_tray_out_of_oven", "method": "bimanualshift", "success": 0.5, "episodes": 10,
             "ci95": [0.2, 0.8], "stages": stages}]
    result = {"command": "bimanualshift study table1", "commit": "abc123def4567890", "created": "2026",
              "machine": "cpu", "seeds": {}, "wall_time_s": 60.0, "rows": rows, "notes": "n", "bench": True,
              "study": "table1"}
    (tmp_path / "t").mkdir()
    (tmp_path / "t" / "summary.json").write_text(json.dumps(result))
    readme = tmp_path / "README.md"
    readme.write_text("<!-- results:t -->\n<!-- /results:t -->\n"
                      "<!-- results:t#headline -->\n<!-- /results:t#headline -->\n")
    assert render_readme(readme, tmp_path) == ["t", "t#headline"]
    full, headline = readme.read_text().split("<!-- results:t#headline -->")
    assert "stage-wise success" in full and "stage-wise success" not in headline
    assert "| bimanualshift | 50 (20–80) |" in headline and "abc123def456" in headline
    with pytest.raises(ValueError, match="unknown results-block view 'brief'"):
        table_for(result, view="brief")
