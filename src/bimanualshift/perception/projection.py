"""Arm-conditioned visual projection (Eq. 1-3): per arm, keep only that arm, the goal and the support.

For each camera: segment "robotic arm" candidates and the goal nouns, give each arm mask to the nearest
base anchor (Eq. 2), and union the arm's mask with the goal mask (Eq. 3). Back-projecting the kept pixels
through depth and intrinsics and voxelising them gives V * M_3D (Eq. 1). The table top is kept as the
local support surface, so the projected scene looks like the single-arm scenes the prior was trained on.

Eq. 2 compares a mask's centroid with the image-plane anchors when both anchors lie inside the image.
Where an anchor falls outside the image (side views, where perspective makes off-image anchors
misleading), the same nearest-anchor rule is applied in 3-D: the mask's pixels are back-projected through
depth and their centroid is compared with the calibrated base positions.

Fallbacks (counted in ``ProjectionDiagnostics``): a camera with no arm mask keeps only goal + support for
both arms; a camera whose anchors lie behind it (wrist cameras) gives its arm masks to the arm it is
mounted on, or to nobody if it is a static camera.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.geometry.cameras import depth_to_world_points
from bimanualshift.perception.anchors import base_anchors, shoulder_position
from bimanualshift.perception.segmenters.base import CameraView, Segmenter
from bimanualshift.sim.segmentation import ARM_CLASS

SUPPORT_CLASS = "table"


@dataclass
class ProjectionDiagnostics:
    cameras: int = 0
    no_arm_found: int = 0
    no_goal_found: int = 0
    anchor_behind_camera: int = 0
    anchor_outside_image: int = 0


def wrist_owner(camera: str) -> str | None:
    return camera.removeprefix("wrist_") if camera.startswith("wrist_") else None


class ArmProjection:
    def __init__(self, segmenter: Segmenter) -> None:
        self.segmenter = segmenter
        self.diagnostics = ProjectionDiagnostics()

    def masks_2d(self, obs: KeyframeObservation) -> dict[str, np.ndarray]:
        """Per arm, a (C, H, W) boolean mask of the pixels that arm's observation keeps."""
        scene = obs.scene
        arms = scene.arm_names
        out = {arm: np.zeros(obs.depth.shape, dtype=bool) for arm in arms}
        prompts = [ARM_CLASS, *scene.goal_nouns, SUPPORT_CLASS]
        for c, camera in enumerate(scene.camera_names):
            self.diagnostics.cameras += 1
            view = CameraView(obs.rgb[c], obs.instance[c], obs.class_ids[c], scene.class_names)
            detections = self.segmenter.segment(view, prompts)
            shared = np.zeros(obs.depth.shape[1:], dtype=bool)
            arm_masks = []
            for det in detections:
                if det.label == ARM_CLASS:
                    arm_masks.append(det.mask)
                else:
                    shared |= det.mask
            if not any(d.label in scene.goal_nouns for d in detections):
                self.diagnostics.no_goal_found += 1
            if not arm_masks:
                self.diagnostics.no_arm_found += 1
            for arm, mask in self.assign_arms(arm_masks, obs, c, camera).items():
                out[arm][c] = mask | shared
        return out

    def assign_arms(self, arm_masks: list[np.ndarray], obs: KeyframeObservation, c: int, camera: str
                    ) -> dict[str, np.ndarray]:
        """Eq. 2: each candidate arm mask goes to the arm whose base anchor is nearest to its centroid."""
        arms = obs.scene.arm_names
        assigned = {arm: np.zeros(obs.depth.shape[1:], dtype=bool) for arm in arms}
        anchors = base_anchors({a: obs.scene.arm_bases[a] for a in arms}, obs.intrinsics[c], obs.extrinsics[c])
        h, w = obs.depth.shape[1:]
        if any(p is None for p in anchors.values()):
            self.diagnostics.anchor_behind_camera += 1
            owner = wrist_owner(camera)
            if owner in assigned:
                for mask in arm_masks:
                    assigned[owner] |= mask
            return assigned
        in_view = all(0 <= p[0] < w and 0 <= p[1] < h for p in anchors.values())
        if not in_view:
            self.diagnostics.anchor_outside_image += 1
            points = depth_to_world_points(obs.depth[c], obs.intrinsics[c], obs.extrinsics[c])
        for mask in arm_masks:
            if in_view:
                rows, cols = np.nonzero(mask)
                centroid, targets = np.array([cols.mean(), rows.mean()]), anchors
            else:
                centroid = points[mask & (obs.depth[c] > 0)].mean(axis=0)
                targets = {a: shoulder_position(obs.scene.arm_bases[a]) for a in arms}
            nearest = min(arms, key=lambda a: float(np.linalg.norm(centroid - targets[a])))
            assigned[nearest] |= mask
        return assigned
