"""The heading anchor: a grasp's orientation taken relative to the goal's own direction, where the demos hold it so.

Where the frozen prior grasps a long object it never saw bimanually (a rope's end, a dustpan's handle), its wrist
yaw is 20-40 degrees off, and the residual, which must output that turn from the goal's geometry, leaves most of it
(docs/residual.md). Yet in such a grasp the expert's yaw is fixed *relative to the object's end*: the direction
into the object from the arm's end (``perception.goal_geometry``'s first extremity) turns with the object, and the
grasp turns with it.

So for each (arm or role block, keyframe slot) of the phase one-hot the training demos decide: the expert's
orientation in the goal's heading frame (Rz(-heading) R) is averaged, and when those relative orientations
cluster tighter than the absolute ones by ``MIN_GAIN_RAD``, that slot is *anchored*: its base orientation is
Rz(heading) times the mean, in place of the prior's. The residual then corrects from there (training, refinement
and inference all see the anchored base). Slots where the goal's heading explains nothing keep the prior's.
"""

from __future__ import annotations

import numpy as np
import torch
from scipy.spatial.transform import Rotation

from bimanualshift.geometry.frames import grasp_twin_mean, gripper_angle_deg
from bimanualshift.perception.goal_geometry import BOX_GEOMETRY_DIM

# this arm's end's horizontal direction into the goal object, in the goal vector (after the box and the end's tip)
HEADING_COLUMNS = slice(BOX_GEOMETRY_DIM + 3, BOX_GEOMETRY_DIM + 5)
FOUND_COLUMN = BOX_GEOMETRY_DIM - 1
MIN_GAIN_RAD = np.deg2rad(5.0)  # a slot is anchored when the relative grasps spread this much less than the absolute
MIN_SAMPLES = 3  # a slot fewer demos reach keeps the prior's orientation


def goal_heading(goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N,) the yaw of this arm's end's direction into the goal object and (N,) whether it was seen."""
    goal = np.asarray(goal, dtype=np.float64).reshape(len(goal), -1)
    if goal.shape[1] < HEADING_COLUMNS.stop:
        raise ValueError(f"a goal vector of {goal.shape[1]} numbers has no extremities; the heading anchor needs "
                         f"at least {HEADING_COLUMNS.stop} (perception.goal_geometry)")
    direction = goal[:, HEADING_COLUMNS]
    seen = (goal[:, FOUND_COLUMN] > 0) & (np.linalg.norm(direction, axis=1) > 0.5)
    return np.arctan2(direction[:, 1], direction[:, 0]), seen


def _spread_rad(quats: np.ndarray, mean: np.ndarray) -> float:
    """The median angle of grasps from their mean, either half-turn twin counting as the same grasp."""
    return float(np.deg2rad(np.median([gripper_angle_deg(q, mean) for q in quats])))


def fit_anchors(phase_index: np.ndarray, phase_dim: int, goal: np.ndarray, quats: np.ndarray
                ) -> tuple[tuple[float, ...], list[dict]]:
    """Per phase slot, the expert's mean grasp in the goal's heading frame (x, y, z, w), or zeros where the slot is
    not anchored; and one report row per slot (samples, the two spreads in degrees, anchored or not)."""
    heading, seen = goal_heading(goal)
    relative = (Rotation.from_euler("z", -heading[:, None]) * Rotation.from_quat(quats)).as_quat()
    anchors, report = [], []
    for slot in range(phase_dim):
        rows = (phase_index == slot) & seen
        entry = {"slot": slot, "samples": int(rows.sum()), "anchored": False}
        anchor = np.zeros(4)
        if rows.sum() >= MIN_SAMPLES:
            rel_mean, abs_mean = grasp_twin_mean(relative[rows]), grasp_twin_mean(quats[rows])
            rel_spread, abs_spread = _spread_rad(relative[rows], rel_mean), _spread_rad(quats[rows], abs_mean)
            entry.update(relative_spread_deg=round(np.rad2deg(rel_spread), 2),
                         absolute_spread_deg=round(np.rad2deg(abs_spread), 2))
            if rel_spread < abs_spread - MIN_GAIN_RAD:
                anchor, entry["anchored"] = rel_mean, True
        anchors.extend(float(v) for v in anchor)
        report.append(entry)
    return tuple(anchors), report


def anchored_quats(anchors: tuple[float, ...], phase_index: np.ndarray, goal: np.ndarray, base_quat: np.ndarray
                   ) -> np.ndarray:
    """(N, 4) the base orientations with each anchored slot's row (goal seen) turned to Rz(heading) * its anchor."""
    table = np.asarray(anchors, dtype=np.float64).reshape(-1, 4)
    out = np.array(base_quat, dtype=np.float64, copy=True)
    heading, seen = goal_heading(goal)
    use = seen & (np.abs(table[phase_index]).sum(axis=1) > 0)
    if use.any():
        turn = Rotation.from_euler("z", heading[use][:, None])
        out[use] = (turn * Rotation.from_quat(table[phase_index[use]])).as_quat()
    return out


def anchored_base(anchors: tuple[float, ...], phase: torch.Tensor, goal: torch.Tensor, base: torch.Tensor
                  ) -> torch.Tensor:
    """``base`` (N, 8: the prior's position, quaternion, gripper) with the anchored slots' orientations, for rows
    whose phase one-hot is ``phase`` and goal geometry ``goal``."""
    quats = anchored_quats(anchors, phase.argmax(-1).numpy(), goal.numpy(), base[:, 3:7].numpy())
    out = base.clone()
    out[:, 3:7] = torch.as_tensor(quats, dtype=base.dtype)
    return out
