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
