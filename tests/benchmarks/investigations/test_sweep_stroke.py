"""investigations/sweep_stroke.py measures the brush arm's set-down against the expert's along and across the stroke."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

ROOT = Path(__file__).resolve().parents[3]
spec = importlib.util.spec_from_file_location("sweep_stroke", ROOT / "benchmarks" / "investigations" /
                                              "sweep_stroke.py")
sweep_stroke = importlib.util.module_from_spec(spec)
spec.loader.exec_module(sweep_stroke)


def _down(yaw: float) -> list[float]:
    """The gripper pointing down, turned by ``yaw`` about the vertical, as an (x, y, z, w) quaternion."""
    return list(Rotation.from_euler("xz", [np.pi, yaw]).as_quat())


def _steps(brush_down: tuple[float, float], turn: float = 0.0, stroke_end: float = 0.0,
           pan_turn: float = 0.0) -> list[dict]:
    """The right arm brushes along -y (from y = 0.2 to y = 0.0) with its gripper turned 0.3 rad; the left arm holds
    still. The executed set-down is ``brush_down``, turned ``turn`` more, and the stroke ends at y = ``stroke_end``."""
    expert = {4: (0.5, 0.2), 5: (0.5, 0.2), 6: (0.5, 0.0)}
    steps = []
    for k in range(7):
        ex = [[0.3, 0.3, 1.0, *_down(0.0), 0, 1], [*expert.get(k, (0.5, 0.3)), 1.0, *_down(0.3), 0, 1]]
        done = [list(ex[0]), list(ex[1])]
        if k == 5:
            done[1][:2] = brush_down
            done[1][3:7] = _down(0.3 + turn)
        if k == 6:
            done[1][1] = stroke_end
        if k == 2:
            done[0][3:7] = _down(pan_turn)
        steps.append({"keyframe": k, "executed": done, "expert": ex})
    return steps


def test_offsets_are_split_along_and_across_the_stroke() -> None:
    found = sweep_stroke.stroke_offsets(_steps((0.52, 0.17)))  # 3 cm short (towards the pan), 2 cm aside
    assert found.along == pytest.approx(-0.03) and abs(found.across) == pytest.approx(0.02)
    assert found.turn == pytest.approx(0.0) and found.end_along == pytest.approx(0.0) and found.pan_turn == 0.0
    assert sweep_stroke.stroke_offsets(_steps((0.5, 0.2))[:5]) is None  # never reached the stroke


def test_head_turn_and_stroke_end() -> None:
    found = sweep_stroke.stroke_offsets(_steps((0.5, 0.2), turn=-0.2, stroke_end=0.04))
    assert found.turn == pytest.approx(-0.2) and found.end_along == pytest.approx(0.04)  # 4 cm before the mouth
    # a parallel gripper looks the same every half turn: turned by pi + 0.1 is 0.1 off
    assert sweep_stroke.stroke_offsets(_steps((0.5, 0.2), turn=np.pi + 0.1)).turn == pytest.approx(0.1)
    assert sweep_stroke.stroke_offsets(_steps((0.5, 0.2), stroke_end=-0.01)).end_along == pytest.approx(-0.01)


def test_the_dustpan_grasp_turn_is_the_other_arms() -> None:
    found = sweep_stroke.stroke_offsets(_steps((0.5, 0.2), turn=0.1, pan_turn=0.6))
    assert found.pan_turn == pytest.approx(0.6) and found.turn == pytest.approx(0.1)
    assert sweep_stroke.stroke_offsets(_steps((0.5, 0.2), pan_turn=-np.pi + 0.2)).pan_turn == pytest.approx(0.2)
    assert np.isnan(found.prior_pan_turn)  # no frozen prior logged


def test_the_frozen_priors_own_dustpan_grasp() -> None:
    steps = _steps((0.5, 0.2), pan_turn=0.2)
    steps[2]["policy"] = {"arms": [{"arm": "left", "prior": [0.3, 0.3, 1.0, *_down(1.3)]},
                                   {"arm": "right", "prior": [0.5, 0.3, 1.0, *_down(0.0)]}]}
    found = sweep_stroke.stroke_offsets(steps)
    assert found.prior_pan_turn == pytest.approx(1.3) and found.pan_turn == pytest.approx(0.2)


def test_summary_per_method_and_outcome(tmp_path: Path) -> None:
    episodes = [{"task": "sweep_to_dustpan", "method": "m", "perturbation": "none", "seed": s, "success": s == 0}
                for s in range(3)]
    logs = [{"task": "sweep_to_dustpan", "method": "m", "perturbation": "none", "seed": s, "steps": _steps(down)}
            for s, down in enumerate([(0.5, 0.21), (0.5, 0.17), (0.5, 0.15)])]
    (tmp_path / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in episodes))
    (tmp_path / "keyframes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in logs))
    rows = {r["outcome"]: r for r in sweep_stroke.summarise(tmp_path)}
    assert rows["success"]["episodes"] == 1 and rows["success"]["along_median_cm"] == pytest.approx(1.0)
    assert rows["failure"]["episodes"] == 2 and rows["failure"]["short_fraction"] == 1.0
    assert rows["failure"]["along_median_cm"] == pytest.approx(-4.0)
    assert rows["failure"]["turn_abs_median_deg"] == 0.0 and rows["failure"]["end_along_median_cm"] == 0.0
