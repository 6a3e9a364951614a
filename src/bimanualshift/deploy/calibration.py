"""Camera-to-base calibration from gripper poses and ArUco marker detections (OpenCV's detector and hand-eye
solver, eye-to-hand: the camera is fixed, the marker rides on the gripper).

OpenCV's ``calibrateHandEye`` solves AX = XB for a camera on the gripper. With the camera fixed and the marker on
the gripper the same solver applies to the inverted gripper poses (base-to-gripper), and returns the camera's
pose in the base frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

ARUCO_DICTIONARY = cv2.aruco.DICT_4X4_50
HAND_EYE_METHODS = {"tsai": cv2.CALIB_HAND_EYE_TSAI, "park": cv2.CALIB_HAND_EYE_PARK,
                    "horaud": cv2.CALIB_HAND_EYE_HORAUD, "andreff": cv2.CALIB_HAND_EYE_ANDREFF,
                    "daniilidis": cv2.CALIB_HAND_EYE_DANIILIDIS}


def marker_cells(marker_id: int, dictionary: int = ARUCO_DICTIONARY) -> np.ndarray:
    """The marker's bits including its black border, (n, n) with 1 = black, row 0 at the top (+y)."""
    d = cv2.aruco.getPredefinedDictionary(dictionary)
    bits = d.markerSize + 2
    return (cv2.aruco.generateImageMarker(d, marker_id, bits) == 0).astype(np.uint8)


@dataclass
class Detection:
    corners: np.ndarray  # (4, 2) pixels: top-left, top-right, bottom-right, bottom-left
    marker_to_camera: np.ndarray  # (4, 4)


def detect_markers(rgb: np.ndarray, dictionary: int = ARUCO_DICTIONARY) -> dict[int, np.ndarray]:
    """Marker id -> its (4, 2) corners (sub-pixel refined) in an RGB image."""
    grey = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2GRAY)
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    detector = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(dictionary), params)
    corners, ids, _ = detector.detectMarkers(grey)
    if ids is None:
        return {}
    return {int(i): c.reshape(4, 2).astype(np.float64) for i, c in zip(ids.ravel(), corners)}


def marker_pose(corners: np.ndarray, intrinsics: np.ndarray, marker_length: float) -> np.ndarray:
    """The marker's pose in the camera frame (OpenCV optical axes) from its four corners."""
    s = marker_length / 2
    points = np.array([[-s, s, 0], [s, s, 0], [s, -s, 0], [-s, -s, 0]], np.float64)
    ok, rvec, tvec = cv2.solvePnP(points, corners.astype(np.float64), np.asarray(intrinsics, np.float64), None,
                                  flags=cv2.SOLVEPNP_IPPE_SQUARE)
    if not ok:
        raise ValueError("solvePnP found no pose for the marker's corners")
    out = np.eye(4)
    out[:3, :3] = cv2.Rodrigues(rvec)[0]
    out[:3, 3] = tvec.ravel()
    return out


def solve_camera_to_base(gripper_to_base: list[np.ndarray], marker_to_camera: list[np.ndarray],
                         method: str = "park") -> np.ndarray:
    """The fixed camera's pose in the robot's base frame (4x4) from >= 3 pairs (gripper pose in the base frame,
    marker pose in the camera frame) with rotations about different axes."""
    if len(gripper_to_base) != len(marker_to_camera) or len(gripper_to_base) < 3:
        raise ValueError(f"hand-eye calibration needs >= 3 pairs of gripper poses and marker detections, got "
                         f"{len(gripper_to_base)} and {len(marker_to_camera)}")
    if method not in HAND_EYE_METHODS:
        raise ValueError(f"unknown hand-eye method {method!r}; choose from {sorted(HAND_EYE_METHODS)}")
    base_to_gripper = [np.linalg.inv(g) for g in gripper_to_base]
    r, t = cv2.calibrateHandEye([m[:3, :3] for m in base_to_gripper], [m[:3, 3] for m in base_to_gripper],
                                [m[:3, :3] for m in marker_to_camera], [m[:3, 3] for m in marker_to_camera],
                                method=HAND_EYE_METHODS[method])
    # the nearest rotation (a degenerate set of pairs can leave the solver's matrix improper)
    u, _, vt = np.linalg.svd(r)
    out = np.eye(4)
    out[:3, :3] = u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt
    out[:3, 3] = t.ravel()
    return out


def mean_link(camera_to_base: np.ndarray, gripper_to_base: list[np.ndarray],
              marker_to_camera: list[np.ndarray]) -> np.ndarray:
    """The marker-to-gripper transform the pairs agree on (their mean)."""
    links = [np.linalg.inv(g) @ camera_to_base @ m for g, m in zip(gripper_to_base, marker_to_camera)]
    out = np.eye(4)
    out[:3, :3] = Rotation.from_matrix(np.stack([x[:3, :3] for x in links])).mean().as_matrix()
    out[:3, 3] = np.mean([x[:3, 3] for x in links], axis=0)
    return out


def link_deviations(camera_to_base: np.ndarray, gripper_to_base: list[np.ndarray],
                    marker_to_camera: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Per pair, how far its marker-to-gripper transform lies from the pairs' mean (mm, degrees): a fixed
    mount makes them all equal, a bad detection stands out."""
    links = [np.linalg.inv(g) @ camera_to_base @ m for g, m in zip(gripper_to_base, marker_to_camera)]
    mean = mean_link(camera_to_base, gripper_to_base, marker_to_camera)
    mean_r = Rotation.from_matrix(mean[:3, :3])
    dt = np.array([1e3 * np.linalg.norm(x[:3, 3] - mean[:3, 3]) for x in links])
    dr = np.array([np.degrees((mean_r.inv() * Rotation.from_matrix(x[:3, :3])).magnitude()) for x in links])
    return dt, dr


def solve_camera_to_base_robust(gripper_to_base: list[np.ndarray], marker_to_camera: list[np.ndarray],
                                method: str = "park", rounds: int = 3) -> tuple[np.ndarray, list[int]]:
    """``solve_camera_to_base`` that drops pairs far from the consensus (a flipped marker pose, a blurred
    corner) and solves again: (camera-to-base, indices of the pairs kept)."""
    kept = list(range(len(gripper_to_base)))
    solution = solve_camera_to_base(gripper_to_base, marker_to_camera, method)
    for _ in range(rounds):
        dt, dr = link_deviations(solution, [gripper_to_base[i] for i in kept], [marker_to_camera[i] for i in kept])
        bad = (dt > 3 * max(np.median(dt), 1.0)) | (dr > 3 * max(np.median(dr), 0.2))
        if not bad.any() or len(kept) - int(bad.sum()) < 5:
            break
        kept = [i for i, b in zip(kept, bad) if not b]
        solution = solve_camera_to_base([gripper_to_base[i] for i in kept], [marker_to_camera[i] for i in kept],
                                        method)
    return solution, kept


def _pose_from_vector(v: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = Rotation.from_rotvec(v[:3]).as_matrix()
    out[:3, 3] = v[3:]
    return out


def _vector_from_pose(m: np.ndarray) -> np.ndarray:
    return np.r_[Rotation.from_matrix(m[:3, :3]).as_rotvec(), m[:3, 3]]


def refine_by_reprojection(camera_to_base: np.ndarray, marker_to_gripper: np.ndarray,
                           gripper_to_base: list[np.ndarray], corners: list[np.ndarray], intrinsics: np.ndarray,
                           marker_length: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The maximum-likelihood fit under pixel noise: camera-to-base and marker-to-gripper that minimise the
    marker corners' reprojection error over every view jointly (scipy's least squares with a Huber loss,
    projection by ``cv2.projectPoints``), started from the hand-eye solution. Per-view PnP poses err most along
    the viewing ray, and the hand-eye solve passes that on; the joint fit does not.
    Returns (camera-to-base, marker-to-gripper, RMS reprojection error in px)."""
    from scipy.optimize import least_squares

    s = marker_length / 2
    points = np.array([[-s, s, 0], [s, s, 0], [s, -s, 0], [-s, -s, 0]], np.float64)
    k = np.asarray(intrinsics, np.float64)

    def residuals(x: np.ndarray) -> np.ndarray:
        base_to_camera = np.linalg.inv(_pose_from_vector(x[:6]))
        mount = _pose_from_vector(x[6:])
        out = []
        for g, c in zip(gripper_to_base, corners):
            m = base_to_camera @ g @ mount
            uv, _ = cv2.projectPoints(points, cv2.Rodrigues(m[:3, :3])[0], m[:3, 3], k, None)
            out.append((uv.reshape(4, 2) - c).ravel())
        return np.concatenate(out)

    x0 = np.r_[_vector_from_pose(camera_to_base), _vector_from_pose(marker_to_gripper)]
    fit = least_squares(residuals, x0, loss="huber", f_scale=1.0, x_scale="jac")
    rms = float(np.sqrt(np.mean(residuals(fit.x) ** 2)))
    return _pose_from_vector(fit.x[:6]), _pose_from_vector(fit.x[6:]), rms


@dataclass
class View:
    """One detection: which camera saw which arm's marker, the arm's reported gripper pose in its base frame,
    and the marker's four corners (pixels)."""

    camera: str
    arm: str
    gripper_to_base: np.ndarray
    corners: np.ndarray


def refine_jointly(views: list[View], intrinsics: dict[str, np.ndarray], marker_length: float,
                   camera_to_world: dict[str, np.ndarray], base_to_world: dict[str, np.ndarray],
                   marker_to_gripper: dict[str, np.ndarray], fixed_arm: str
                   ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict[str, np.ndarray], float]:
    """Every camera, every arm's base (but ``fixed_arm``'s, which defines the world) and every marker mount
    fitted at once to all views' corners (least squares, Huber loss, ``cv2.projectPoints``): a camera seen by
    both arms' markers and a base seen by several cameras are each estimated from all their data.
    Returns (camera-to-world, base-to-world, marker-to-gripper, RMS reprojection error in px)."""
    from scipy.optimize import least_squares

    s = marker_length / 2
    points = np.array([[-s, s, 0], [s, s, 0], [s, -s, 0], [-s, -s, 0]], np.float64)
    cams = sorted({v.camera for v in views})
    arms = sorted({v.arm for v in views})
    free_bases = [a for a in arms if a != fixed_arm]
    blocks = [("camera", c) for c in cams] + [("base", a) for a in free_bases] + [("mount", a) for a in arms]
    start = {("camera", c): camera_to_world[c] for c in cams}
    start.update({("base", a): base_to_world[a] for a in free_bases})
    start.update({("mount", a): marker_to_gripper[a] for a in arms})
    x0 = np.concatenate([_vector_from_pose(start[b]) for b in blocks])
    index = {b: 6 * i for i, b in enumerate(blocks)}

    def unpack(x: np.ndarray) -> dict[tuple[str, str], np.ndarray]:
        out = {b: _pose_from_vector(x[index[b]:index[b] + 6]) for b in blocks}
        out[("base", fixed_arm)] = base_to_world[fixed_arm]
        return out

    def residuals(x: np.ndarray) -> np.ndarray:
        poses = unpack(x)
        world_to_camera = {c: np.linalg.inv(poses[("camera", c)]) for c in cams}
        out = []
        for v in views:
            m = world_to_camera[v.camera] @ poses[("base", v.arm)] @ v.gripper_to_base @ poses[("mount", v.arm)]
            uv, _ = cv2.projectPoints(points, cv2.Rodrigues(m[:3, :3])[0], m[:3, 3],
                                      np.asarray(intrinsics[v.camera], np.float64), None)
            out.append((uv.reshape(4, 2) - v.corners).ravel())
        return np.concatenate(out)

    fit = least_squares(residuals, x0, loss="huber", f_scale=1.0, x_scale="jac")
    poses = unpack(fit.x)
    rms = float(np.sqrt(np.mean(residuals(fit.x) ** 2)))
    return ({c: poses[("camera", c)] for c in cams}, {a: poses[("base", a)] for a in arms},
            {a: poses[("mount", a)] for a in arms}, rms)


def pose_error(estimate: np.ndarray, truth: np.ndarray) -> tuple[float, float]:
    """(translation error in mm, rotation error in degrees) between two 4x4 poses."""
    dt = 1e3 * float(np.linalg.norm(estimate[:3, 3] - truth[:3, 3]))
    dr = float(np.degrees(Rotation.from_matrix(estimate[:3, :3].T @ truth[:3, :3]).magnitude()))
    return dt, dr
