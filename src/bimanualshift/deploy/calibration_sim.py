"""Calibration on the benchmark scene: an ArUco marker rides on a simulated gripper, the arm visits poses, the
static cameras render full-resolution views, and the solver's camera poses are compared with the simulator's.

The marker is a plate of black and white cells (its bits from OpenCV's dictionary) on a mocap body that follows
the gripper at a fixed mount the solver does not know. Noise is added where a real setup has it: Gaussian noise
on the detected corners (pixels) and on the reported gripper poses (millimetres, degrees).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation
from tqdm import tqdm

from bimanualshift.deploy.calibration import (
    HAND_EYE_METHODS,
    View,
    detect_markers,
    marker_cells,
    marker_pose,
    mean_link,
    pose_error,
    refine_by_reprojection,
    refine_jointly,
    solve_camera_to_base_robust,
)
from bimanualshift.deploy.robot import Calibration, pose_matrix
from bimanualshift.sim.cameras import CameraRig
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.task_registry import make_task

MARKER_ID = 7
MIN_PAIRS = 8  # views of one arm's marker a camera needs before its hand-eye solve starts the joint fit
MARKER_BODY = "calibration_marker"
# Where the marker sits on the gripper, given with the gripper at its home orientation (pointing down): on a
# paddle 14 cm forward of the fingers and 4 cm up, its face turned up and 30 degrees towards the front, clear of
# the arm's links for the static cameras.
MOUNT_OFFSET_WORLD = np.array([0.14, 0.0, 0.04])
MOUNT_FACING = Rotation.from_euler("y", 30, degrees=True)


def marker_mount(home_quat: np.ndarray) -> np.ndarray:
    """The marker's fixed pose in the gripper frame (the unknown a hand-eye solve eliminates)."""
    home = Rotation.from_quat(home_quat)
    mount = np.eye(4)
    mount[:3, :3] = (home.inv() * MOUNT_FACING).as_matrix()
    mount[:3, 3] = home.inv().apply(MOUNT_OFFSET_WORLD)
    return mount


def marker_xml(marker_length: float) -> str:
    """A white plate with the marker's black cells on top of it (marker frame: z out of the face)."""
    cells = marker_cells(MARKER_ID)
    n = len(cells)
    cell = marker_length / n
    plate = marker_length / 2 + cell  # a one-cell white margin
    # the cells' faces lie in the marker's plane (z = 0), the plate's 0.2 mm behind them
    geoms = [f'<geom type="box" size="{plate} {plate} 0.002" pos="0 0 -0.0022" rgba="1 1 1 1" contype="0" '
             'conaffinity="0" group="1"/>']
    for r in range(n):
        for c in range(n):
            if cells[r, c]:
                x, y = -marker_length / 2 + (c + 0.5) * cell, marker_length / 2 - (r + 0.5) * cell
                geoms.append(f'<geom type="box" size="{cell / 2} {cell / 2} 0.0005" pos="{x} {y} -0.0005" '
                             'rgba="0 0 0 1" contype="0" conaffinity="0" group="1"/>')
    return f'<body name="{MARKER_BODY}" mocap="true" pos="0 0 2">{"".join(geoms)}</body>'


@dataclass
class CalibrationRun:
    """What a simulated calibration measured, per camera and arm."""

    rows: list[dict[str, Any]] = field(default_factory=list)
    calibration: Calibration = field(default_factory=Calibration)
    reprojection_rms_px: float = 0.0
    detector_error_px_median: float | None = None  # noise-free detection against the true corners


def calibration_poses(env: ManipulationEnv, arm: str, n: int, rng: np.random.Generator) -> list[np.ndarray]:
    """``n`` gripper poses (world, x y z qx qy qz qw) in front of ``arm``: positions in a box
    (30 x 30 x 20 cm), the gripper tilted up to 35 degrees about random horizontal axes and turned up to 90
    degrees about its own."""
    a = env.arm_names.index(arm)
    home = env.proprio()[a]
    centre = np.array([0.0, 0.6 * env.arm_frames[arm].position[1], 1.05])
    base = Rotation.from_quat(home[3:7])
    poses = []
    for _ in range(n):
        pos = centre + rng.uniform([-0.15, -0.15, -0.1], [0.15, 0.15, 0.1])
        axis = np.r_[rng.normal(size=2), 0.0]
        tilt = Rotation.from_rotvec(axis / np.linalg.norm(axis) * np.radians(rng.uniform(5, 35)))
        turn = Rotation.from_euler("z", rng.uniform(-90, 90), degrees=True)
        poses.append(np.r_[pos, (tilt * base * turn).as_quat()])
    return poses


def _place_marker(env: ManipulationEnv, gripper_to_world: np.ndarray, mount: np.ndarray) -> np.ndarray:
    marker = gripper_to_world @ mount
    body = env.model.body(MARKER_BODY)
    env.data.mocap_pos[body.mocapid[0]] = marker[:3, 3]
    env.data.mocap_quat[body.mocapid[0]] = np.roll(Rotation.from_matrix(marker[:3, :3]).as_quat(), 1)  # w first
    mujoco.mj_forward(env.model, env.data)
    return marker


def simulate_calibration(task: str = "push_two_buttons", poses: int = 40, width: int = 1280, height: int = 960,
                         marker_length: float = 0.08, pixel_noise: float = 0.5, position_noise_mm: float = 1.0,
                         rotation_noise_deg: float = 0.2, method: str = "park", seed: int = 0) -> CalibrationRun:
    """Each arm visits ``poses`` poses; every static camera that detects the marker gives a view. Per camera and
    arm, OpenCV's hand-eye solve (outliers dropped) starts a joint reprojection fit of all cameras, the second
    arm's base and both mounts (``refine_jointly``). Rows: per camera and arm the hand-eye result, per camera
    and per arm base the final one, each against the simulator's truth."""
    rng = np.random.default_rng(seed)
    task_obj = make_task(task)
    scene_xml = task_obj.scene_xml
    task_obj.scene_xml = lambda: scene_xml() + marker_xml(marker_length)  # type: ignore[method-assign]
    env = ManipulationEnv(task_obj)
    env.reset(seed=0, options={"render": False})
    cameras = tuple(env.robot.static_cameras)
    rig = CameraRig(env.model, cameras, env.cameras.mujoco_names, height=height, width=width, samples=8,
                    fovy=env.robot.camera_fovy)
    truth_cameras = {c: rig.extrinsics(env.data, c) for c in cameras}
    k = opencv_intrinsics(rig.intrinsics())
    truth_bases = {}
    for arm in env.arm_names:
        truth_bases[arm] = np.eye(4)
        truth_bases[arm][:3, 3] = env.arm_frames[arm].position  # the simulated bases are not rotated
    views: list[View] = []
    marker_poses: list[np.ndarray] = []  # PnP per view, for the hand-eye start
    detector_px: list[float] = []
    for arm in env.arm_names:
        a = env.arm_names.index(arm)
        mount = marker_mount(env.proprio()[a, 3:7])
        for target in tqdm(calibration_poses(env, arm, poses, rng), desc=f"calibrate {arm}", unit="pose"):
            action = np.stack([np.r_[env.proprio()[i, :7], 1.0, 0.0] for i in range(len(env.arm_names))])
            action[a, :7] = target
            env.step(action, render=False)
            pos, quat = env.eef_pose(a)
            gripper_to_world = pose_matrix(np.r_[pos, quat])
            marker = _place_marker(env, gripper_to_world, mount)
            # what the robot reports: its pose in its own base frame, with encoder and kinematic noise
            noisy = np.linalg.inv(truth_bases[arm]) @ gripper_to_world
            noisy[:3, 3] += rng.normal(0, position_noise_mm / 1e3, 3)
            noisy[:3, :3] = Rotation.from_rotvec(rng.normal(0, np.radians(rotation_noise_deg), 3)).as_matrix() \
                @ noisy[:3, :3]
            frames = rig.render(env.data, depth_and_segmentation=False)
            for cam in cameras:
                found = detect_markers(frames[cam].rgb).get(MARKER_ID)
                if found is None:
                    continue
                truth_m2c = np.linalg.inv(truth_cameras[cam]) @ marker
                detector_px.append(float(np.abs(found - _project(truth_m2c, k, marker_length)).max()))
                corners = found + rng.normal(0, pixel_noise, found.shape)
                views.append(View(cam, arm, noisy, corners))
                marker_poses.append(marker_pose(corners, k, marker_length))
    rig.close()

    run = CalibrationRun()
    first = env.arm_names[0]
    hand_eye: dict[tuple[str, str], np.ndarray] = {}
    mounts: dict[str, np.ndarray] = {}
    fit_rms: dict[tuple[str, str], float] = {}
    links: dict[tuple[str, str], np.ndarray] = {}
    for cam in cameras:
        for arm in env.arm_names:
            idx = [i for i, v in enumerate(views) if v.camera == cam and v.arm == arm]
            row: dict[str, Any] = {"stage": "hand_eye", "camera": cam, "arm": arm, "poses": poses,
                                   "detections": len(idx)}
            if len(idx) >= MIN_PAIRS:
                grippers = [views[i].gripper_to_base for i in idx]
                markers = [marker_poses[i] for i in idx]
                # OpenCV's hand-eye solvers, then the same camera and arm refined on their own corners; the
                # requested method first, another where it degenerates (its refit explains the corners worst)
                best = None
                for name in [method, *(m for m in HAND_EYE_METHODS if m != method)]:
                    solution, kept = solve_camera_to_base_robust(grippers, markers, name)
                    link = mean_link(solution, [grippers[i] for i in kept], [markers[i] for i in kept])
                    refined, link, rms = refine_by_reprojection(
                        solution, link, [grippers[i] for i in kept], [views[idx[i]].corners for i in kept], k,
                        marker_length)
                    if best is None or rms < best[3]:
                        best = (name, solution, kept, rms, refined, link)
                    if rms < 2.0:
                        break
                name, solution, kept, rms, refined, link = best
                dt, dr = pose_error(truth_bases[arm] @ solution, truth_cameras[cam])
                hand_eye[(cam, arm)], fit_rms[(cam, arm)], links[(cam, arm)] = refined, rms, link
                row.update({"method": name, "pairs_kept": len(kept), "translation_error_mm": round(dt, 2),
                            "rotation_error_deg": round(dr, 3), "pair_fit_rms_px": round(rms, 3)})
            run.rows.append(row)
    world_from_first = truth_bases[first]  # the world frame: the first arm's base where the benchmark puts it
    good = {key for key, rms in fit_rms.items() if rms < 3.0}  # a start that does not explain its own views is left out
    start_cams = {c: world_from_first @ hand_eye[(c, first)] for c in cameras if (c, first) in good}
    start_bases = {first: world_from_first}
    for arm in env.arm_names[1:]:
        shared = sorted((fit_rms[(c, arm)], c) for c in start_cams if (c, arm) in good)
        if not shared:
            raise RuntimeError(f"no camera saw both {first}'s and {arm}'s marker well: the bases cannot be related")
        best = shared[0][1]
        start_bases[arm] = start_cams[best] @ np.linalg.inv(hand_eye[(best, arm)])
    for arm in env.arm_names:  # each mount from the camera whose own fit explains that arm's views best
        rms_cam = min((fit_rms[(c, arm)], c) for c in start_cams if (c, arm) in good)[1]
        mounts[arm] = links[(rms_cam, arm)]
    used = [v for v in views if v.camera in start_cams]
    cams_fit, bases_fit, _, rms = refine_jointly(used, {c: k for c in start_cams}, marker_length, start_cams,
                                                start_bases, mounts, first)
    for cam, pose in cams_fit.items():
        dt, dr = pose_error(pose, truth_cameras[cam])
        run.rows.append({"stage": "joint", "camera": cam, "detections": sum(v.camera == cam for v in used),
                         "translation_error_mm": round(dt, 2), "rotation_error_deg": round(dr, 3)})
    for arm in env.arm_names[1:]:
        dt, dr = pose_error(bases_fit[arm], truth_bases[arm])
        run.rows.append({"stage": "joint", "arm_base": arm, "translation_error_mm": round(dt, 2),
                         "rotation_error_deg": round(dr, 3)})
    run.reprojection_rms_px = rms
    run.detector_error_px_median = float(np.median(detector_px)) if detector_px else None
    run.calibration = Calibration(
        intrinsics={c: env.cameras.intrinsics().tolist() for c in env.camera_names},  # the deployment's size
        extrinsics={c: pose.tolist() for c, pose in cams_fit.items()},
        arm_bases={arm: [float(v) for v in pose[:3, 3]] for arm, pose in bases_fit.items()},
        source=f"bimanualshift calibrate --robot sim: OpenCV ArUco detection, calibrateHandEye ({method}, "
               f"eye-to-hand) then a joint reprojection fit; {len(used)} views, RMS {rms:.2f} px")
    env.close()
    return run


def opencv_intrinsics(k: np.ndarray) -> np.ndarray:
    """The renderer's K puts pixel i's centre at i + 0.5; OpenCV's detections put it at i."""
    out = np.array(k, np.float64)
    out[0, 2] -= 0.5
    out[1, 2] -= 0.5
    return out


def _project(marker_to_camera: np.ndarray, intrinsics: np.ndarray, length: float) -> np.ndarray:
    s = length / 2
    pts = np.array([[-s, s, 0, 1], [s, s, 0, 1], [s, -s, 0, 1], [-s, -s, 0, 1]]) @ marker_to_camera.T
    uv = pts[:, :3] @ np.asarray(intrinsics).T
    return uv[:, :2] / uv[:, 2:3]

