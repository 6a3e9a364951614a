"""The heading anchor: a keyframe slot's grasp orientation taken from the demos, where they hold it steadier than
the frozen prior proposes it.

Where the frozen prior grasps an object it never saw bimanually (a rope's end, a dustpan's handle), its wrist yaw
is 20-40 degrees off, and the residual, which must output that turn from the goal's geometry, leaves most of it
(docs/residual.md). Yet the demos' grasp at such a slot is steady in one of two frames: the table's (sweep's
dustpan arm grasps within 3-5 degrees of one yaw) or the goal's end direction (the rope's grasps spread 21-24
degrees on the table but 3-6 degrees relative to the direction into the rope from its end:
results/issue54/heading_anchor_fit.json). The end direction is ``perception.goal_geometry``'s first extremity.

So for each (arm or role block, keyframe) slot of the phase one-hot the training demos decide. The expert's
orientations are averaged in both frames (half-turn twins counting as one grasp), and the steadier frame is kept.
When its spread is below the prior's own median error on those demos by ``MIN_GAIN_RAD``, the slot is *anchored*:
its base orientation is that mean (turned by the end's direction in the goal's frame) in place of the prior's.
The residual then corrects from there: training, refinement and inference all see the anchored base. Other slots
keep the prior's orientation.
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
MIN_GAIN_RAD = np.deg2rad(5.0)  # a slot is anchored when its demos' spread is this much below the prior's error
MIN_SAMPLES = 3  # a slot fewer demos reach keeps the prior's orientation
ANCHOR_WIDTH = 5  # per slot: the frame (0 none, 1 the table's, 2 the goal end's) and the mean grasp (x, y, z, w)
FRAMES = ("none", "table", "goal")


def goal_heading(goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N,) the yaw of this arm's end's direction into the goal object and (N,) whether it was seen."""
    goal = np.asarray(goal, dtype=np.float64).reshape(len(goal), -1)
    if goal.shape[1] < HEADING_COLUMNS.stop:
        raise ValueError(f"a goal vector of {goal.shape[1]} numbers has no extremities; the heading anchor needs "
                         f"at least {HEADING_COLUMNS.stop} (perception.goal_geometry)")
    direction = goal[:, HEADING_COLUMNS]
    seen = (goal[:, FOUND_COLUMN] > 0) & (np.linalg.norm(direction, axis=1) > 0.5)
    return np.arctan2(direction[:, 1], direction[:, 0]), seen


def _median_angle(quats: np.ndarray, reference: np.ndarray) -> float:
    """The median angle (radians) of grasps from ``reference`` (one, or one per grasp), either half-turn twin
    counting as the same grasp."""
    reference = np.broadcast_to(reference, quats.shape)
    return float(np.deg2rad(np.median([gripper_angle_deg(q, r) for q, r in zip(quats, reference, strict=True)])))


def fit_anchors(phase_index: np.ndarray, phase_dim: int, goal: np.ndarray, quats: np.ndarray,
                prior_quats: np.ndarray | None = None) -> tuple[tuple[float, ...], list[dict]]:
    """Per phase slot ``ANCHOR_WIDTH`` numbers (the frame, then the mean grasp; all zeros where the slot keeps the
    prior's), and one report row per slot: samples, each frame's spread and the prior's error in degrees, the frame
    chosen. Without ``prior_quats`` a frame must beat the other by ``MIN_GAIN_RAD`` instead (the goal's frame only:
    the demos alone cannot say whether the table's beats the prior)."""
    heading, seen = goal_heading(goal)
    quats = np.asarray(quats, dtype=np.float64)
    relative = (Rotation.from_euler("z", -heading[:, None]) * Rotation.from_quat(quats)).as_quat()
    anchors, report = [], []
    for slot in range(phase_dim):
        rows = (phase_index == slot) & seen
        entry: dict = {"slot": slot, "samples": int(rows.sum()), "frame": "none"}
        anchor = np.zeros(ANCHOR_WIDTH)
        if rows.sum() >= MIN_SAMPLES:
            means = {"table": grasp_twin_mean(quats[rows]), "goal": grasp_twin_mean(relative[rows])}
            spread = {"table": _median_angle(quats[rows], means["table"]),
                      "goal": _median_angle(relative[rows], means["goal"])}
            entry.update({f"{f}_spread_deg": round(float(np.rad2deg(s)), 2) for f, s in spread.items()})
            if prior_quats is not None:
                prior_error = _median_angle(np.asarray(prior_quats, np.float64)[rows], quats[rows])
                entry["prior_error_deg"] = round(float(np.rad2deg(prior_error)), 2)
                frame = min(spread, key=spread.get)
                bar = prior_error
            else:
                frame, bar = "goal", spread["table"]
            if spread[frame] < bar - MIN_GAIN_RAD:
                anchor = np.r_[FRAMES.index(frame), means[frame]]
                entry["frame"] = frame
        anchors.extend(float(v) for v in anchor)
        report.append(entry)
    return tuple(anchors), report


def anchored_quats(anchors: tuple[float, ...], phase_index: np.ndarray, goal: np.ndarray, base_quat: np.ndarray,
                   scene_yaw: np.ndarray | None = None) -> np.ndarray:
    """(N, 4) the base orientations with each anchored slot's rows set to its mean grasp: in the table's frame as
    it is (turned by ``scene_yaw``, a training copy's rigid turn of the whole scene), in the goal's turned by the
    row's goal end direction (where that end was seen)."""
    table = np.asarray(anchors, dtype=np.float64).reshape(-1, ANCHOR_WIDTH)
    out = np.array(base_quat, dtype=np.float64, copy=True)
    frame, grasp = table[phase_index, 0].round().astype(int), table[phase_index, 1:]
    heading, seen = goal_heading(goal)
    fixed = frame == FRAMES.index("table")
    if fixed.any():
        turn = np.zeros(len(out)) if scene_yaw is None else np.asarray(scene_yaw, np.float64)
        out[fixed] = (Rotation.from_euler("z", turn[fixed][:, None]) * Rotation.from_quat(grasp[fixed])).as_quat()
    turned = (frame == FRAMES.index("goal")) & seen
    if turned.any():
        out[turned] = (Rotation.from_euler("z", heading[turned][:, None]) * Rotation.from_quat(grasp[turned])).as_quat()
    return out


def anchored_base(anchors: tuple[float, ...], phase: torch.Tensor, goal: torch.Tensor, base: torch.Tensor,
                  scene_yaw: torch.Tensor | None = None) -> torch.Tensor:
    """``base`` (N, 8: the prior's position, quaternion, gripper) with the anchored slots' orientations, for rows
    whose phase one-hot is ``phase`` and goal geometry ``goal`` (``scene_yaw``: as ``anchored_quats``)."""
    quats = anchored_quats(anchors, phase.argmax(-1).numpy(), goal.numpy(), base[:, 3:7].numpy(),
                           None if scene_yaw is None else scene_yaw.numpy())
    out = base.clone()
    out[:, 3:7] = torch.as_tensor(quats, dtype=base.dtype)
    return out
