"""Calibration: the solver recovers a known camera exactly from exact pairs, the detector finds a rendered
marker where it is, and the whole simulated calibration lands near the simulator's truth under noise."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bimanualshift.deploy.calibration import (
    detect_markers,
    marker_pose,
    pose_error,
    solve_camera_to_base,
    solve_camera_to_base_robust,
)
from bimanualshift.deploy.calibration_sim import simulate_calibration
from bimanualshift.deploy.robot import Calibration


def random_pose(rng: np.random.Generator, spread_m: float, spread_rad: float) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = Rotation.from_rotvec(rng.normal(0, spread_rad, 3)).as_matrix()
    m[:3, 3] = rng.normal(0, spread_m, 3)
    return m


def test_eye_to_hand_solve_is_exact_on_exact_pairs_and_drops_a_bad_one() -> None:
    rng = np.random.default_rng(0)
    camera_to_base, mount = random_pose(rng, 1.0, 2.0), random_pose(rng, 0.1, 1.0)
    grippers = [random_pose(rng, 0.2, 0.5) for _ in range(15)]
    markers = [np.linalg.inv(camera_to_base) @ g @ mount for g in grippers]
    dt, dr = pose_error(solve_camera_to_base(grippers, markers), camera_to_base)
    assert dt < 1e-6 and dr < 1e-6
    markers[3] = markers[3] @ random_pose(rng, 0.05, 0.5)  # one flipped / misdetected marker
    solution, kept = solve_camera_to_base_robust(grippers, markers)
    assert 3 not in kept and pose_error(solution, camera_to_base)[0] < 1e-3
    with pytest.raises(ValueError, match=">= 3 pairs"):
        solve_camera_to_base(grippers[:2], markers[:2])


def test_marker_pose_from_synthetic_corners() -> None:
    k = np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]])
    truth = np.eye(4)
    truth[:3, :3] = Rotation.from_euler("xy", [20, -10], degrees=True).as_matrix()
    truth[:3, 3] = (0.05, -0.02, 0.8)
    s = 0.04
    pts = np.array([[-s, s, 0, 1], [s, s, 0, 1], [s, -s, 0, 1], [-s, -s, 0, 1]]) @ truth.T
    uv = pts[:, :3] @ k.T
    corners = uv[:, :2] / uv[:, 2:]
    dt, dr = pose_error(marker_pose(corners, k, 2 * s), truth)
    assert dt < 1e-3 and dr < 1e-3
    assert detect_markers(np.full((64, 64, 3), 255, np.uint8)) == {}


@pytest.mark.slow
# the Pandas' four cameras at 640x480 (half the rendering of 960x720; seed 1 solves front and overhead within 6 mm and
# 0.4 deg there); the twin's one camera at 960x720
@pytest.mark.parametrize(("task", "size"), [("push_two_buttons", (640, 480)), ("vegetable_sorting", (960, 720))])
def test_simulated_calibration_is_close_to_the_truth(tmp_path, task: str, size: tuple[int, int]) -> None:  # noqa: ANN001
    """15 poses per arm with 0.5 px and 1 mm / 0.2 deg noise (the committed runs use 40 poses at 1280x960:
    results/calibration.json, results/calibration_ur5e.json). On the UR5e twin the one front camera is the only
    view, so it alone places the second base."""
    run = simulate_calibration(task=task, poses=15, width=size[0], height=size[1], seed=1)
    joint = [r for r in run.rows if r["stage"] == "joint"]
    cameras = [r for r in joint if "camera" in r and r["detections"] >= 20]
    assert cameras, run.rows
    assert max(r["translation_error_mm"] for r in cameras) < 12
    assert max(r["rotation_error_deg"] for r in cameras) < 1.0
    base = next(r for r in joint if "arm_base" in r)
    assert base["translation_error_mm"] < 10
    path = run.calibration.save(tmp_path / "calibration.json")
    loaded = Calibration.load(path)
    assert set(loaded.arm_bases) == {"left", "right"} and loaded.extrinsics.keys() == run.calibration.extrinsics.keys()
    if task == "vegetable_sorting":
        assert set(loaded.extrinsics) == {"front"}  # the twin's one camera
    else:  # at 15 poses the over-shoulder cameras see the marker too rarely to be solved
        assert {"front", "overhead"} <= set(loaded.extrinsics)
    assert np.allclose(loaded.arm_bases["right"], [-0.56, -0.3, 0.912], atol=0.01)
