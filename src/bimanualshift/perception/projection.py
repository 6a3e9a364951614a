"""Arm-conditioned visual projection (Eq. 1-3): per arm, keep only that arm, the goal and the support.

For each camera: segment "robotic arm" candidates and the goal nouns, give each arm mask to the nearest
base anchor (Eq. 2), and union the arm's mask with the goal mask (Eq. 3). Back-projecting the kept pixels
through depth and intrinsics and voxelising them gives V * M_3D (Eq. 1). The table top is kept as the
local support surface, so the projected scene looks like the single-arm scenes the prior was trained on.

Eq. 2 compares a mask's centroid with the image-plane anchors when both anchors lie inside the image.
Where an anchor falls outside the image (side views, where perspective makes off-image anchors
misleading), the same nearest-anchor rule is applied in 3-D: the mask's pixels are back-projected through
depth and their centroid is compared with the calibrated base positions.

Hard cases, each with a defined fallback counted in ``ProjectionDiagnostics`` (none raises):

* no arm found in a camera: both arms keep only goal + support there (``no_arm_found``);
* the two arms merged into one mask (crossing arms: fewer arm candidates than arms, and the candidate's
  back-projected points lie substantially on both sides of the plane half-way between the bases and near
  both shoulders): the mask is split pixel by pixel, each pixel going to the base on its side
  (``merged_arms_split``);
* goal object not found: the arms keep themselves and the support (``no_goal_found``);
* missing depth (a camera whose depth is all zero / NaN): that camera contributes nothing to the voxels
  (``missing_depth``); pixels without depth are simply not back-projected, and a mask whose pixels have no
  depth is assigned with its image-plane centroid (``mask_without_depth``);
* anchors behind the camera (wrist cameras): arm masks go to the arm the camera is mounted on, or to nobody
  for a static camera (``anchor_behind_camera``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.geometry.pixel_voxels import pixel_voxel_index, voxel_occupancy, world_rays
from bimanualshift.geometry.voxels import VoxelGrid
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
    merged_arms_split: int = 0
    missing_depth: int = 0
    mask_without_depth: int = 0

# A candidate counts as two merged arms when at least this fraction of its points lies on each side.
MERGED_SIDE_FRACTION = 0.2
MERGED_SHOULDER_RADIUS = 0.3  # metres: a merged mask holds points this close to both shoulders


def wrist_owner(camera: str) -> str | None:
    return camera.removeprefix("wrist_") if camera.startswith("wrist_") else None


class CameraPoints:
    """Back-projects chosen pixels of one camera to world points, through rays cached per camera pose."""

    def __init__(self, obs: KeyframeObservation, c: int) -> None:
        h, w = obs.depth.shape[1:]
        rays, origins = world_rays(obs.intrinsics[c:c + 1], obs.extrinsics[c:c + 1], h, w)
        self.rays, self.origin, self.depth = rays[:, 0], origins[:, 0, 0, 0], obs.depth[c]

    def at(self, mask: np.ndarray) -> np.ndarray:
        """World points (N, 3) of the pixels of ``mask``, in row-major order."""
        return self.origin + self.depth[mask][:, None] * self.rays[:, mask].T

    def centroid(self, mask: np.ndarray) -> np.ndarray:
        """Mean world point of the pixels of ``mask`` (which must all have depth), as one mat-vec product."""
        weights = np.where(mask, self.depth, np.float32(0.0)).ravel()
        return self.origin + self.rays.reshape(3, -1) @ weights / np.count_nonzero(mask)


class ArmProjection:
    def __init__(self, segmenter: Segmenter) -> None:
        self.segmenter = segmenter
        self.diagnostics = ProjectionDiagnostics()
        self._anchor_cache: dict[tuple, dict[str, np.ndarray | None]] = {}

    def voxel_masks(self, obs: KeyframeObservation, grid: VoxelGrid,
                    world_to_frame: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
        """M_3D per arm (Eq. 1): the (S, S, S) voxels of ``grid`` that the arm's kept pixels fall in.

        ``world_to_frame`` gives, per arm, the 4x4 transform into the frame the grid is expressed in (an
        arm-centric grid); by default the grid is in world coordinates.
        """
        masks = self.masks_2d(obs)
        out = {}
        for arm, mask in masks.items():
            transform = None if world_to_frame is None else world_to_frame[arm]
            index = pixel_voxel_index(obs.depth, obs.intrinsics, obs.extrinsics, grid, transform)
            out[arm] = voxel_occupancy(index, mask, grid.size)
        return out

    def masks_2d(self, obs: KeyframeObservation) -> dict[str, np.ndarray]:
        """Per arm, a (C, H, W) boolean mask of the pixels that arm's observation keeps."""
        return self.project(obs)[0]

    def project(self, obs: KeyframeObservation) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """Per arm, the (C, H, W) mask of the pixels that arm's observation keeps, and the goal objects' own
        (C, H, W) mask (for its location, see ``goal_geometry``)."""
        kept, goal, _ = self.project_objects(obs)
        return kept, goal

    def project_objects(self, obs: KeyframeObservation
                        ) -> tuple[dict[str, np.ndarray], np.ndarray, dict[str, np.ndarray]]:
        """``project``'s masks, and each goal noun's own (C, H, W) mask, in the order of the scene's goal nouns."""
        scene = obs.scene
        arms = scene.arm_names
        out = {arm: np.zeros(obs.depth.shape, dtype=bool) for arm in arms}
        goal = np.zeros(obs.depth.shape, dtype=bool)
        objects = {noun: np.zeros(obs.depth.shape, dtype=bool) for noun in scene.goal_nouns}
        prompts = [ARM_CLASS, *scene.goal_nouns, SUPPORT_CLASS]
        colours = [scene.instance_colours.get(name, []) for name in scene.instance_names] \
            if scene.instance_colours else None
        has_depth = obs.depth > 0  # False for NaN too
        for c, camera in enumerate(scene.camera_names):
            self.diagnostics.cameras += 1
            if not has_depth[c].any():
                self.diagnostics.missing_depth += 1  # nothing to back-project: the camera adds no voxels
                continue
            view = CameraView(obs.rgb[c], obs.instance[c], obs.class_ids[c], scene.class_names, colours)
            detections = self.segmenter.segment(view, prompts)
            shared = np.zeros(obs.depth.shape[1:], dtype=bool)
            arm_masks = []
            for det in detections:
                if det.label == ARM_CLASS:
                    arm_masks.append(det.mask)
                else:
                    shared |= det.mask
                    if det.label in objects:
                        goal[c] |= det.mask
                        objects[det.label][c] |= det.mask
            if not any(d.label in scene.goal_nouns for d in detections):
                self.diagnostics.no_goal_found += 1
            if not arm_masks:
                self.diagnostics.no_arm_found += 1
            for arm, mask in self.assign_arms(arm_masks, obs, c, camera, has_depth[c]).items():
                np.logical_or(mask, shared, out=out[arm][c])
        return out, goal, objects

    def _anchors(self, obs: KeyframeObservation, c: int) -> dict[str, np.ndarray | None]:
        """Image-plane base anchors of camera c, cached: they change only when the camera or a base moves."""
        bases = {a: obs.scene.arm_bases[a] for a in obs.scene.arm_names}
        key = (obs.intrinsics[c].tobytes(), obs.extrinsics[c].tobytes(), repr(bases))
        if key not in self._anchor_cache:
            if len(self._anchor_cache) > 256:
                self._anchor_cache.clear()
            self._anchor_cache[key] = base_anchors(bases, obs.intrinsics[c], obs.extrinsics[c])
        return self._anchor_cache[key]

    def assign_arms(self, arm_masks: list[np.ndarray], obs: KeyframeObservation, c: int, camera: str,
                    has_depth: np.ndarray) -> dict[str, np.ndarray]:
        """Eq. 2: each candidate arm mask goes to the arm whose base anchor is nearest to its centroid."""
        arms = obs.scene.arm_names
        assigned = {arm: np.zeros(obs.depth.shape[1:], dtype=bool) for arm in arms}
        if not arm_masks:
            return assigned
        anchors = self._anchors(obs, c)
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
        points = CameraPoints(obs, c)
        shoulders = {a: shoulder_position(obs.scene.arm_bases[a]) for a in arms}
        for mask in arm_masks:
            if len(arms) == 2 and len(arm_masks) < len(arms):
                split = self._split_if_merged(mask, points, has_depth, shoulders, anchors)
                if split is not None:
                    self.diagnostics.merged_arms_split += 1
                    for arm in arms:
                        assigned[arm] |= split[arm]
                    continue
            usable = mask & has_depth
            if in_view or not usable.any():
                if not in_view:
                    self.diagnostics.mask_without_depth += 1
                rows, cols = np.nonzero(mask)
                centroid, targets = np.array([cols.mean(), rows.mean()]), anchors
            else:
                centroid, targets = points.centroid(usable), shoulders
            nearest = min(arms, key=lambda a: float(np.linalg.norm(centroid - targets[a])))
            assigned[nearest] |= mask
        return assigned

    @staticmethod
    def _split_if_merged(mask: np.ndarray, points: CameraPoints, has_depth: np.ndarray,
                         shoulders: dict[str, np.ndarray], anchors: dict[str, np.ndarray | None]
                         ) -> dict[str, np.ndarray] | None:
        """Pixel-wise nearest-base split of a mask that holds both arms, or None if it holds one."""
        (arm_a, base_a), (arm_b, base_b) = shoulders.items()
        normal = (base_a - base_b)[:2]
        middle = (base_a + base_b)[:2] / 2
        usable = mask & has_depth
        if usable.sum() < 20:
            return None
        pts = points.at(usable)
        on_a_usable = (pts[:, :2] - middle) @ normal > 0
        fraction_a = float(on_a_usable.mean())
        if min(fraction_a, 1 - fraction_a) < MERGED_SIDE_FRACTION:
            return None
        # One arm reaching across the middle is not two arms: a merged mask reaches both shoulders.
        near = [np.sum(np.linalg.norm(pts - s, axis=-1) < MERGED_SHOULDER_RADIUS) for s in (base_a, base_b)]
        if min(near) < 10:
            return None
        # Pixels with depth go to the side of the plane they lie on; those without follow the nearer
        # image-plane anchor.
        rows, cols = np.indices(mask.shape)
        uv = np.stack([cols, rows], axis=-1).astype(float)
        side_a = np.linalg.norm(uv - anchors[arm_a], axis=-1) < np.linalg.norm(uv - anchors[arm_b], axis=-1)
        side_a[usable] = on_a_usable
        return {arm_a: mask & side_a, arm_b: mask & ~side_a}
