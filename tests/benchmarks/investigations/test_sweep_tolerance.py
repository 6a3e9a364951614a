"""investigations/sweep_tolerance.py changes only the brush arm's stroke: aside, turned and cut short as asked."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bimanualshift.sim.task import ArmAction

ROOT = Path(__file__).resolve().parents[3]
spec = importlib.util.spec_from_file_location("sweep_tolerance", ROOT / "benchmarks" / "investigations" /
                                              "sweep_tolerance.py")
sweep_tolerance = importlib.util.module_from_spec(spec)
spec.loader.exec_module(sweep_tolerance)

DOWN = Rotation.from_euler("x", np.pi).as_quat()  # the gripper pointing down


def _keyframes() -> list[dict[str, ArmAction]]:
    """The right arm strokes along -y from keyframe 4 (y = 0.2) to 6 (y = 0.0); the left arm holds the pan."""
    brush_y = {4: 0.2, 5: 0.2, 6: 0.0, 7: 0.0}
    return [{"left": ArmAction(np.array([0.3, 0.3, 1.0]), DOWN, 0.0),
             "right": ArmAction(np.array([0.5, brush_y.get(k, 0.4), 1.0]), DOWN, 1.0 if k < 2 else 0.0)}
            for k in range(8)]


def _heading(quat: np.ndarray) -> float:
    x = Rotation.from_quat(quat).apply([1.0, 0.0, 0.0])
    return float(np.arctan2(x[1], x[0]))


def test_only_the_brush_arms_stroke_changes() -> None:
    before = _keyframes()
    after = sweep_tolerance.change_stroke(before, sweep_tolerance.StrokeChange(0.02, 0.3, 0.015), "right")
    for k in range(8):
        np.testing.assert_array_equal(after[k]["left"].position, before[k]["left"].position)
        assert abs(np.dot(after[k]["left"].quat, before[k]["left"].quat)) == pytest.approx(1.0)
        shift = after[k]["right"].position - before[k]["right"].position
        turned = _heading(after[k]["right"].quat) - _heading(before[k]["right"].quat)
        if k in (4, 5):  # stroke along -y: its left is +x
            assert shift == pytest.approx([0.02, 0.0, 0.0]) and turned == pytest.approx(0.3)
        elif k in (6, 7):  # and its end pulled back towards the start, +y
            assert shift == pytest.approx([0.02, 0.015, 0.0]) and turned == pytest.approx(0.3)
        else:
            assert shift == pytest.approx([0.0, 0.0, 0.0]) and turned == pytest.approx(0.0)
        assert after[k]["right"].gripper_open == before[k]["right"].gripper_open
        # the gripper still points down
        assert Rotation.from_quat(after[k]["right"].quat).apply([0, 0, 1.0])[2] == pytest.approx(-1.0)
    assert before[5]["right"].position[0] == 0.5  # the expert's keyframes are left as they were


def test_no_change_keeps_the_expert() -> None:
    before = _keyframes()
    after = sweep_tolerance.change_stroke(before, sweep_tolerance.StrokeChange(0.0, 0.0, 0.0), "right")
    for k in range(8):
        np.testing.assert_allclose(after[k]["right"].position, before[k]["right"].position)
        assert abs(np.dot(after[k]["right"].quat, before[k]["right"].quat)) == pytest.approx(1.0)


def test_the_dustpan_grasp_turns_in_place() -> None:
    before = _keyframes()
    after = sweep_tolerance.change_stroke(before, sweep_tolerance.StrokeChange(0.0, 0.0, 0.0, pan_turn_rad=-0.5),
                                         "right")
    for k in range(8):
        np.testing.assert_array_equal(after[k]["left"].position, before[k]["left"].position)
        assert _heading(after[k]["left"].quat) - _heading(before[k]["left"].quat) == pytest.approx(-0.5)
        np.testing.assert_allclose(after[k]["right"].position, before[k]["right"].position)
        assert abs(np.dot(after[k]["right"].quat, before[k]["right"].quat)) == pytest.approx(1.0)


def test_the_brush_arm_is_the_tasks_own() -> None:
    from bimanualshift.sim.env import ManipulationEnv

    env = ManipulationEnv("sweep_to_dustpan", image_size=64)
    try:  # the brush arm's keyframes 4 and 6 (the stroke) lie farther apart than the pan arm's
        for seed in (100000, 100001):
            env.reset(seed=seed, options={"render": False})
            keyframes = env.expert_keyframes()
            pan_arm, brush_arm = env.task.roles(env.sim)
            span = {a: np.linalg.norm(keyframes[4][a].position[:2] - keyframes[6][a].position[:2])
                    for a in (pan_arm, brush_arm)}
            assert span[brush_arm] > span[pan_arm] + 0.05
    finally:
        env.close()
