"""Image-plane base anchors b_L, b_R: the calibrated robot base positions projected into each camera."""

from __future__ import annotations

import numpy as np

from bimanualshift.geometry.cameras import project_world_points

# The base body sits at floor level under the shoulder; anchor on the shoulder, which cameras see.
SHOULDER_HEIGHT_ABOVE_BASE = 0.33


def shoulder_position(base: list[float]) -> np.ndarray:
    return np.asarray(base, float) + [0.0, 0.0, SHOULDER_HEIGHT_ABOVE_BASE]


def base_anchors(arm_bases: dict[str, list[float]], intrinsics: np.ndarray, extrinsics: np.ndarray
                 ) -> dict[str, np.ndarray | None]:
    """Pixel (u, v) of each arm's shoulder in one camera, or None if it is behind the camera."""
    world_to_cam = np.linalg.inv(extrinsics)
    anchors: dict[str, np.ndarray | None] = {}
    for arm, base in arm_bases.items():
        p = shoulder_position(base)
        depth = (world_to_cam[:3, :3] @ p + world_to_cam[:3, 3])[2]
        anchors[arm] = project_world_points(p, intrinsics, extrinsics) if depth > 0 else None
    return anchors
