"""From a multi-camera keyframe to one arm's observation: voxels and proprioception in its base frame."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.geometry.cameras import depth_to_world_points
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.geometry.pixel_voxels import pixel_voxel_index, voxel_occupancy, voxelize_pixels
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.goal_geometry import (
    GOAL_GEOMETRY_DIM,
    OBJECT_GEOMETRY_DIM,
    goal_geometry,
    goal_world_points,
    object_boxes,
)
from bimanualshift.perception.projection import ArmProjection

# Arm-frame workspace: 0.2-0.9 m ahead of the base, +-0.45 m to the side, from just below the table top
# (the base sits 0.11 m below it) to 0.35 m above the base: 2.2 x 2.8 x 1.6 cm voxels at 32^3.
DEFAULT_ARM_BOUNDS = (0.2, -0.45, -0.15, 0.9, 0.45, 0.35)


@dataclass
class ArmObservation:
    voxels: np.ndarray | None  # (4, S, S, S) float32 occupancy + rgb, arm frame; None if the builder skips voxels
    proprio: np.ndarray  # (8,) position, quaternion, gripper open in the arm frame
    other_proprio: np.ndarray  # (8,) the other arm's proprio in this arm's frame; zeros for a single arm
    # (GOAL_GEOMETRY_DIM,) the goal's location in this arm's frame (zeros without a projection or a seen goal)
    goal: np.ndarray = field(default_factory=lambda: np.zeros(GOAL_GEOMETRY_DIM, np.float32))
    # (P, 6) arm-frame xyz (metres) and rgb in [0, 1] of the pixels the voxels are made of (the same projection
    # mask), for priors that read the cloud itself; None unless the builder was asked for ``points``.
    points: np.ndarray | None = None


def world_point_cloud(obs: KeyframeObservation) -> tuple[np.ndarray, np.ndarray]:
    """All cameras' pixels as world points (C, H, W, 3) and colours in [0, 1] (C, H, W, 3)."""
    points = np.stack([depth_to_world_points(obs.depth[c], obs.intrinsics[c], obs.extrinsics[c])
                       for c in range(len(obs.depth))])
    return points, obs.rgb.astype(np.float32) / 255.0


def arm_frames(obs: KeyframeObservation) -> dict[str, ArmFrame]:
    return {arm: ArmFrame(tuple(obs.scene.arm_bases[arm])) for arm in obs.scene.arm_names}


def proprio_in_arm_frame(proprio_world: np.ndarray, frame: ArmFrame) -> np.ndarray:
    pos, quat = frame.pose_to_arm(proprio_world[:3], proprio_world[3:7])
    return np.r_[pos, quat, proprio_world[7]].astype(np.float32)


def fixed_subsample(indices: np.ndarray, limit: int) -> np.ndarray:
    """At most ``limit`` of ``indices``, in their order: above it, a subsample fixed by their count alone (no global
    RNG), so the same pixels give the same points in every process."""
    if len(indices) <= limit:
        return indices
    return np.sort(np.random.default_rng(len(indices)).choice(indices, limit, replace=False))


def arm_point_cloud(world: tuple[np.ndarray, np.ndarray], keep: np.ndarray, frame: ArmFrame, limit: int
                    ) -> np.ndarray:
    """(P <= limit, 6) arm-frame xyz and rgb of the kept pixels; above ``limit``, a subsample fixed by the pixel
    count alone (no global RNG), in pixel order."""
    points, colours = world
    chosen = fixed_subsample(np.flatnonzero(keep.ravel()), limit)
    xyz = frame.points_to_arm(points.reshape(-1, 3)[chosen])
    return np.concatenate([xyz, colours.reshape(-1, 3)[chosen]], axis=1).astype(np.float32)


class ArmObservationBuilder:
    """Builds each arm's voxel observation, through the arm-conditioned projection when one is given.

    With a projection, an arm's observation is V * M_3D (Eq. 1): the voxelised scene in the arm's frame, with
    every voxel that none of the arm's kept pixels (itself, the goal, the support) falls in set to zero; its
    goal mask also gives the goal's location (``ArmObservation.goal``).
    """

    def __init__(self, grid: VoxelGrid, projection: ArmProjection | None = None, mask_voxels: bool = True,
                 points: int = 0, voxels: bool = True, goal_objects: bool = False) -> None:
        self.grid = grid
        self.projection = projection
        self.mask_voxels = mask_voxels  # False: segment only to locate the goal, the voxels stay global
        self.points = points  # > 0: also each arm's point cloud, at most this many points (a fixed subsample)
        # False: no voxel grid (a point-cloud prior's pretraining never reads one; 256 KB a sample at 32^3)
        self.voxels = voxels
        # True: also each goal noun's own box (``object_boxes``), one back-projection per noun; only a residual
        # that reads past the union's geometry needs them, for the rest those columns stay zero
        self.goal_objects = goal_objects
        if not voxels and not points:
            raise ValueError("an ArmObservationBuilder without voxels must keep points (points > 0)")

    def build(self, obs: KeyframeObservation) -> dict[str, ArmObservation]:
        masks, goal_mask, object_masks = self.projection.project_objects(obs) if self.projection else (None, None, {})
        world = world_point_cloud(obs) if self.points else None
        goal_points = goal_world_points(obs, goal_mask) if goal_mask is not None else np.zeros((0, 3), np.float32)
        object_points = ([goal_world_points(obs, mask) for mask in object_masks.values()] if self.goal_objects
                         else None)
        out = {}
        n = len(obs.scene.arm_names)
        for i, (arm, frame) in enumerate(arm_frames(obs).items()):
            index = pixel_voxel_index(obs.depth, obs.intrinsics, obs.extrinsics, self.grid, frame.world_to_base)
            voxels = voxelize_pixels(index, obs.rgb, self.grid.size) if self.voxels else None
            keep = index >= 0
            if masks is not None and self.mask_voxels:
                if voxels is not None:
                    voxels *= voxel_occupancy(index, masks[arm], self.grid.size)
                keep &= masks[arm]
            other = proprio_in_arm_frame(obs.proprio[1 - i], frame) if n == 2 else np.zeros(8, np.float32)
            cloud = arm_point_cloud(world, keep, frame, self.points) if world is not None else None
            boxes = (object_boxes(object_points, frame, self.grid.bounds) if object_points is not None
                     else np.zeros(OBJECT_GEOMETRY_DIM, np.float32))
            goal = np.r_[goal_geometry(goal_points, frame, self.grid.bounds), boxes]
            out[arm] = ArmObservation(voxels, proprio_in_arm_frame(obs.proprio[i], frame), other, goal, cloud)
        return out
