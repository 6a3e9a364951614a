"""benchmarks/keyframe_precision.py splits each arm's first-grasp error into the prior's, the policy's and the
executor's parts, from a bench folder's keyframe log."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "keyframe_precision.py"
spec = importlib.util.spec_from_file_location("keyframe_precision", SCRIPT)
precision = importlib.util.module_from_spec(spec)
spec.loader.exec_module(precision)

DOWN = [1.0, 0.0, 0.0, 0.0]  # gripper down, (x, y, z, w)
TURNED = [0.9961947, 0.0871557, 0.0, 0.0]  # gripper down turned 10 degrees about the vertical


def _row(k: int, expert: list, executed: list, reached: list, prior: list) -> dict:
    return {"keyframe": k, "expert": expert, "executed": executed, "reached": reached, "stages_done": 0,
            "policy": {"arms": [{"arm": a, "prior": p} for a, p in zip(("left", "right"), prior)]}}


def _write(folder: Path) -> None:
    # left arm: approach (open) at keyframe 0, grasp (closes) at 1; right arm grasps at keyframe 0
    steps = [
        _row(0, expert=[[0.5, 0.2, 1.0, *DOWN, 1, 0], [0.5, -0.2, 1.0, *DOWN, 0, 0]],
             executed=[[0.5, 0.2, 1.0, *DOWN, 1, 0], [0.53, -0.2, 1.0, *DOWN, 0, 0]],
             reached=[[0.5, 0.2, 1.0, *DOWN, 1], [0.53, -0.2, 1.01, *DOWN, 0]],
             prior=[[0.4, 0.2, 1.0, *DOWN], [0.6, -0.2, 1.0, *DOWN]]),
        _row(1, expert=[[0.5, 0.2, 0.9, *DOWN, 0, 0], [0.5, -0.2, 1.1, *DOWN, 0, 0]],
             executed=[[0.5, 0.205, 0.9, *TURNED, 0, 0], [0.5, -0.2, 1.1, *DOWN, 0, 0]],
             reached=[[0.5, 0.205, 0.9, *TURNED, 0], [0.5, -0.2, 1.1, *DOWN, 0]],
             prior=[[0.5, 0.2, 0.8, *DOWN], [0.5, -0.2, 1.1, *DOWN]]),
    ]
    folder.mkdir()
    (folder / "keyframes.jsonl").write_text(json.dumps({"task": "t", "method": "m", "perturbation": "none",
                                                        "seed": 7, "steps": steps}) + "\n")
    (folder / "episodes.jsonl").write_text(json.dumps({"task": "t", "method": "m", "perturbation": "none",
                                                       "seed": 7, "success": False}) + "\n")


def test_each_arms_first_grasp_is_split_into_its_terms(tmp_path: Path) -> None:
    _write(tmp_path / "f")
    grasps = precision.grasp_errors(json.loads((tmp_path / "f" / "keyframes.jsonl").read_text())["steps"])
    left, right = grasps
    assert (left["arm"], left["keyframe"], right["arm"], right["keyframe"]) == (0, 1, 1, 0)
    assert left["prior"][0] == pytest.approx(10.0) and left["policy"] == pytest.approx((0.5, 10.0), abs=1e-3)
    assert left["executor"] == pytest.approx((0.0, 0.0), abs=1e-3)
    assert right["policy"][0] == pytest.approx(3.0) and right["executor"][0] == pytest.approx(1.0)
    assert right["reached"][0] == pytest.approx((3 ** 2 + 1) ** 0.5, abs=1e-3)


def test_the_script_writes_medians_and_the_share_within_the_target(tmp_path: Path) -> None:
    _write(tmp_path / "f")
    done = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path / "f"), "--methods", "m",
                           "--out", str(tmp_path / "p.json")], capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "p.json").read_text())
    assert result["seeds"] == {"t": [7]}
    pooled = next(r for r in result["rows"] if r["task"] == "all")
    assert pooled["grasps"] == 2 and pooled["reached"]["within_target"] == 0.0  # 10 degrees off; 3.2 cm off
    assert pooled["policy"]["cm"][1] == pytest.approx(1.75)
    only_successes = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path / "f"), "--methods", "m",
                                     "--episodes", "successes"], capture_output=True, text=True, cwd=ROOT)
    assert only_successes.returncode != 0 and "no unperturbed episode" in only_successes.stderr
    assert "Traceback" not in only_successes.stderr


def test_a_prior_reports_keyframe_log_reads_with_the_prior_as_the_method(tmp_path: Path) -> None:
    _write(tmp_path / "f")
    (tmp_path / "r.keyframes.jsonl").write_text((tmp_path / "f" / "keyframes.jsonl").read_text())
    (tmp_path / "r.episodes.jsonl").write_text(json.dumps({"prior": "m", "task": "t", "seed": 7, "success": True,
                                                           "keyframes": 2}) + "\n")
    rows = precision.precision_rows(tmp_path / "r.keyframes.jsonl", ["m"], success=True)
    assert next(r for r in rows if r["task"] == "all")["grasps"] == 2
    with pytest.raises(ValueError, match="no unperturbed episode"):
        precision.precision_rows(tmp_path / "r.keyframes.jsonl", ["m"], success=False)
