import json
from pathlib import Path

from bimanualshift.evaluation.markdown import render_readme


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

    from bimanualshift.evaluation.markdown import render_readme

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
    from bimanualshift.evaluation.markdown import table_for

    table = table_for({
        "command": "python benchmarks/collection_speed.py", "commit": "abcdef0123456789", "created": "now",
        "machine": "m", "wall_time_s": 120, "notes": "n", "seeds": {"train": [0]},
        "rows": [{"task": "lift_ball", "workers": 1, "episodes_per_min": 6.25, "extra": {"ignored": 1}},
                 {"task": "lift_ball", "workers": 2, "episodes_per_min": 11.5, "extra": {"ignored": 1}}],
    })
    lines = table.splitlines()
    assert lines[0] == "| task | workers | episodes per min |"
    assert lines[2:4] == ["| lift_ball | 1 | 6.250 |", "| lift_ball | 2 | 11.500 |"]
    assert "`python benchmarks/collection_speed.py` at commit `abcdef012345`" in table
