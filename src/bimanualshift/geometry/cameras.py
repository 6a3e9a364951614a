"""Pinhole camera model: metric depth <-> world points.

Conventions (OpenCV style): the camera looks along +z, x to the right, y down in the image.
``intrinsics`` is the 3x3 matrix K, ``extrinsics`` the 4x4 camera-to-world transform of that
optical frame. Images are row 0 at the top.
"""

from __future__ import annotations

import numpy as np


def _check_camera(depth: np.ndarray, intrinsics: np.ndarray, extrinsics: np.ndarray) -> None:
    if depth.ndim != 2:
        raise ValueError(f"depth must be a 2-D (H, W) array of metres, got shape {depth.shape}")
    if intrinsics.shape != (3, 3):
        raise ValueError(f"intrinsics must be a 3x3 matrix, got shape {intrinsics.shape}")
    if extrinsics.shape != (4, 4):
        raise ValueError(f"extrinsics must be a 4x4 camera-to-world matrix, got shape {extrinsics.shape}")


def depth_to_camera_points(depth: np.ndarray, intrinsics: np.ndarray) -> np.ndarray:
    """Back-project every pixel to a 3-D point in the camera's optical frame, shape (H, W, 3)."""
    h, w = depth.shape
    fx, fy = intrinsics[0, 0], intrinsics[1, 1]
    cx, cy = intrinsics[0, 2], intrinsics[1, 2]
    u = np.arange(w, dtype=np.float32)[None, :]
    v = np.arange(h, dtype=np.float32)[:, None]
    z = depth.astype(np.float32)
    x = (u - cx) / fx * z
    y = (v - cy) / fy * z
    return np.stack([x, y, z], axis=-1)


def depth_to_world_points(depth: np.ndarray, intrinsics: np.ndarray, extrinsics: np.ndarray) -> np.ndarray:
    """Back-project a metric depth map to world coordinates, shape (H, W, 3)."""
    _check_camera(depth, intrinsics, extrinsics)
    cam = depth_to_camera_points(depth, intrinsics)
    rot = extrinsics[:3, :3].astype(np.float32)
    trans = extrinsics[:3, 3].astype(np.float32)
    return cam @ rot.T + trans


def project_world_points(points: np.ndarray, intrinsics: np.ndarray, extrinsics: np.ndarray) -> np.ndarray:
    """Project world points (..., 3) to pixel coordinates (..., 2) as (u, v) = (column, row)."""
    world_to_cam = np.linalg.inv(extrinsics)
    cam = points @ world_to_cam[:3, :3].T + world_to_cam[:3, 3]
    z = np.clip(cam[..., 2:3], 1e-6, None)
    uv = (cam[..., :2] / z) * np.array([intrinsics[0, 0], intrinsics[1, 1]]) + intrinsics[:2, 2]
    return uv


def view_coverage(low: np.ndarray, high: np.ndarray, intrinsics: np.ndarray, extrinsics: np.ndarray,
                  image_size: tuple[int, int], samples: int = 7, near: float = 0.05, far: float = 5.0) -> float:
    """The fraction of a world box (a ``samples``^3 lattice of points) that lies inside at least one camera's
    image, between ``near`` and ``far`` metres in front of it (an RGB-D camera's range): what a set of views can
    see of a workspace before anything occludes it.
    ``intrinsics`` (N, 3, 3), ``extrinsics`` (N, 4, 4) camera-to-world, ``image_size`` (height, width)."""
    axes = [np.linspace(lo, hi, samples) for lo, hi in zip(low, high)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    h, w = image_size
    seen = np.zeros(len(points), bool)
    for k, e in zip(intrinsics, extrinsics):
        world_to_cam = np.linalg.inv(np.asarray(e, np.float64))
        z = points @ world_to_cam[2, :3] + world_to_cam[2, 3]
        u, v = project_world_points(points, np.asarray(k, np.float64), np.asarray(e, np.float64)).T
        seen |= (z > near) & (z < far) & (u >= 0) & (u < w) & (v >= 0) & (v < h)
    return float(seen.mean())
