"""Where the goal object is, in an arm's frame: a few numbers from the projection's goal mask.

The frozen prior's pooled features say little about *where* things are, and the residual must move the
prior's target by tens of centimetres on tasks the prior never saw. The projection already segments the goal
object named in the instruction (Eq. 3); back-projecting those pixels through depth gives its points, and
their robust extent in the arm's frame is a precise, cheap location cue for the Manager (Eq. 6).
"""

from __future__ import annotations

import numpy as np

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.perception.projection import CameraPoints

GOAL_GEOMETRY_DIM = 3 + 3 + 3 + 1  # centroid, 5th and 95th percentile corners, found flag
MIN_GOAL_POINTS = 10  # fewer back-projected goal points than this count as "goal not seen"


def goal_world_points(obs: KeyframeObservation, goal_mask: np.ndarray) -> np.ndarray:
    """(N, 3) world points of the goal pixels (``goal_mask`` is (C, H, W)) that have a valid depth, through the
    projection's cached camera rays (only the goal's pixels are back-projected)."""
    parts = []
    for c in range(len(obs.depth)):
        mask = goal_mask[c] & (obs.depth[c] > 0)  # False for NaN depth too
        if mask.any():
            parts.append(CameraPoints(obs, c).at(mask))
    return np.concatenate(parts) if parts else np.zeros((0, 3), np.float32)


def goal_geometry(points_world: np.ndarray, frame: ArmFrame, bounds: tuple[float, ...]) -> np.ndarray:
    """(GOAL_GEOMETRY_DIM,) the goal's centroid and robust extent in ``frame``, counting only points inside the
    arm's workspace ``bounds`` (x0, y0, z0, x1, y1, z1); all zeros when the goal is not seen."""
    out = np.zeros(GOAL_GEOMETRY_DIM, np.float32)
    if len(points_world) == 0:
        return out
    points = frame.points_to_arm(np.asarray(points_world, np.float64))
    low, high = np.asarray(bounds[:3]), np.asarray(bounds[3:])
    points = points[np.all((points >= low) & (points <= high), axis=1)]
    if len(points) < MIN_GOAL_POINTS:
        return out
    out[0:3] = points.mean(0)
    out[3:6] = np.percentile(points, 5, axis=0)
    out[6:9] = np.percentile(points, 95, axis=0)
    out[9] = 1.0
    return out
