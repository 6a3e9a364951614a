"""benchmarks/sweep_offset.py moves only the brush arm's stroke, and only across it."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from bimanualshift.sim.task import ArmAction

ROOT = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("sweep_offset", ROOT / "benchmarks" / "sweep_offset.py")
sweep_offset = importlib.util.module_from_spec(spec)
spec.loader.exec_module(sweep_offset)

QUAT = np.array([1.0, 0.0, 0.0, 0.0])


def _keyframes() -> list[dict[str, ArmAction]]:
    """The right arm strokes along -y from keyframe 4 (y = 0.2) to 6 (y = 0.0); the left arm holds the pan."""
    brush_y = {4: 0.2, 5: 0.2, 6: 0.0, 7: 0.0}
    return [{"left": ArmAction(np.array([0.3, 0.3, 1.0]), QUAT, 0.0),
             "right": ArmAction(np.array([0.5, brush_y.get(k, 0.4), 1.0]), QUAT, 1.0 if k < 2 else 0.0)}
            for k in range(8)]


def test_only_the_brush_arms_stroke_moves_across() -> None:
    before = _keyframes()
    after = sweep_offset.offset_stroke(before, 0.02)
    for k in range(8):
        np.testing.assert_array_equal(after[k]["left"].position, before[k]["left"].position)
        shift = after[k]["right"].position - before[k]["right"].position
        if k in (4, 5, 6, 7):  # stroke along -y: its left is +x
            assert shift == pytest.approx([0.02, 0.0, 0.0])
        else:
            assert shift == pytest.approx([0.0, 0.0, 0.0])
        assert after[k]["right"].gripper_open == before[k]["right"].gripper_open
    assert before[5]["right"].position[0] == 0.5  # the expert's keyframes are left as they were
    assert sweep_offset.offset_stroke(before, -0.01)[5]["right"].position[0] == pytest.approx(0.49)
