"""From a multi-camera keyframe to one arm's observation: voxels and proprioception in its base frame."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.geometry.cameras import depth_to_world_points
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.geometry.pixel_voxels import pixel_voxel_index, voxel_occupancy, voxelize_pixels
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.goal_geometry import GOAL_GEOMETRY_DIM, goal_geometry, goal_world_points
from bimanualshift.perception.projection import ArmProjection

# Arm-frame workspace: 0.2-0.9 m ahead of the base, +-0.45 m to the side, from just below the table top
# (the base sits 0.11 m below it) to 0.35 m above the base: 2.2 x 2.8 x 1.6 cm voxels at 32^3.
DEFAULT_ARM_BOUNDS = (0.2, -0.45, -0.15, 0.9, 0.45, 0.35)


@dataclass
class ArmObservation:
    voxels: np.ndarray  # (4, S, S, S) float32 occupancy + rgb, arm frame
    proprio: np.ndarray  # (8,) position, quaternion, gripper open in the arm frame
    other_proprio: np.ndarray  # (8,) the other arm's proprio in this arm's frame; zeros for a single arm
    # (GOAL_GEOMETRY_DIM,) the goal's location in this arm's frame (zeros without a projection or a seen goal)
    goal: np.ndarray = field(default_factory=lambda: np.zeros(GOAL_GEOMETRY_DIM, np.float32))


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


class ArmObservationBuilder:
    """Builds each arm's voxel observation, through the arm-conditioned projection when one is given.

    With a projection, an arm's observation is V * M_3D (Eq. 1): the voxelised scene in the arm's frame, with
    every voxel that none of the arm's kept pixels (itself, the goal, the support) falls in set to zero; its
    goal mask also gives the goal's location (``ArmObservation.goal``).
    """

    def __init__(self, grid: VoxelGrid, projection: ArmProjection | None = None, mask_voxels: bool = True) -> None:
        self.grid = grid
        self.projection = projection
        self.mask_voxels = mask_voxels  # False: segment only to locate the goal, the voxels stay global

    def build(self, obs: KeyframeObservation) -> dict[str, ArmObservation]:
        masks, goal_mask = self.projection.project(obs) if self.projection else (None, None)
        goal_points = goal_world_points(obs, goal_mask) if goal_mask is not None else np.zeros((0, 3), np.float32)
        out = {}
        n = len(obs.scene.arm_names)
        for i, (arm, frame) in enumerate(arm_frames(obs).items()):
            index = pixel_voxel_index(obs.depth, obs.intrinsics, obs.extrinsics, self.grid, frame.world_to_base)
            voxels = voxelize_pixels(index, obs.rgb, self.grid.size)
            if masks is not None and self.mask_voxels:
                voxels *= voxel_occupancy(index, masks[arm], self.grid.size)
            other = proprio_in_arm_frame(obs.proprio[1 - i], frame) if n == 2 else np.zeros(8, np.float32)
            out[arm] = ArmObservation(voxels, proprio_in_arm_frame(obs.proprio[i], frame), other,
                                      goal_geometry(goal_points, frame, self.grid.bounds))
        return out
