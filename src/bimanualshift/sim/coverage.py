"""Where the bimanual tasks put their goal objects in each arm's own frame, against where the matching single-arm
pretraining task puts the same object (its arm at y = 0).

A frozen single-arm prior serves either arm because observations and actions are expressed in the arm's base
frame; that works only where, in that frame, the single-arm data covers the bimanual layouts. Poses come from the
tasks' own ``initialize_episode`` (an env reset per seed, nothing rendered), never from a declared table.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.props.rope import rope_ends

# Bimanual task -> {goal object: the single-arm task with the same object ("" when the suite has none)}.
SKILL_PAIRS: dict[str, dict[str, str]] = {
    "push_two_buttons": {"button": "push_button"},
    "lift_ball": {"ball": ""},
    "pick_up_plate": {"plate": "pick_up_small_plate"},
    "take_tray_out_of_oven": {"oven": "open_oven_door", "tray": "take_tray_out_of_open_oven"},
    "straighten_rope": {"rope_end": "pull_rope_end"},
    "sweep_to_dustpan": {"dustpan": "drag_dustpan", "brush": "sweep_dirt"},
    "buttons_then_lift_ball": {"button": "push_button", "ball": ""},
}
ON_TABLE_X = 1.0  # unused buttons are parked beyond this (off the table, out of view)


def _yaw(quat_wxyz: np.ndarray) -> float:
    w, x, y, z = quat_wxyz
    return float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


def object_poses(env: ManipulationEnv, obj: str) -> np.ndarray:
    """(k, 3) world x, y and yaw of every instance of ``obj`` in the env's current scene."""
    sim, model = env.sim, env.model
    if obj == "rope_end":
        return np.array([[*end[:2], 0.0] for end in rope_ends(sim, "rope")])
    names = [model.body(i).name for i in range(model.nbody) if model.body_parentid[i] == 0]
    chosen = [n for n in names if n == obj or (obj == "button" and n.startswith("button_"))]
    poses = []
    for name in chosen:
        b = sim.body_id(name)
        if sim.data.xpos[b][0] < ON_TABLE_X:
            poses.append([*sim.data.xpos[b][:2], _yaw(sim.data.xquat[b])])
    return np.array(poses).reshape(-1, 3)


def arm_frame_poses(task: str, obj: str, seeds: list[int]) -> dict[str, np.ndarray]:
    """Per arm, (n, 3) x, y and yaw of ``obj`` in that arm's base frame over the episodes of ``seeds``."""
    env = ManipulationEnv(task, image_size=32)
    out: dict[str, list[np.ndarray]] = {arm: [] for arm in env.arm_frames}
    for seed in seeds:
        env.reset(seed=seed, options={"render": False})
        world = object_poses(env, obj)
        for arm, frame in env.arm_frames.items():
            base = np.asarray(frame.position)
            out[arm].append(np.c_[world[:, :2] - base[:2], world[:, 2] - frame.yaw])
    env.close()
    return {arm: np.concatenate(rows) for arm, rows in out.items()}


@dataclass
class Coverage:
    """One bimanual (task, object, arm) against its single-arm task: the ranges of each and the share of the
    bimanual poses that fall inside the single-arm poses' box (x, y and, for oriented objects, yaw)."""

    task: str
    obj: str
    arm: str
    single_arm_task: str
    bimanual_range: list[list[float]]  # [[min, max]] for x, y, yaw
    single_arm_range: list[list[float]] | None
    inside: float | None  # share of bimanual poses inside the single-arm box


def _ranges(poses: np.ndarray) -> list[list[float]]:
    return [[round(float(poses[:, i].min()), 3), round(float(poses[:, i].max()), 3)] for i in range(3)]


def coverage(task: str, seeds: list[int], single_arm_seeds: list[int], use_yaw: bool = True) -> list[Coverage]:
    rows = []
    for obj, single in SKILL_PAIRS[task].items():
        bimanual = arm_frame_poses(task, obj, seeds)
        reference = arm_frame_poses(single, obj, single_arm_seeds)["right"] if single else None
        for arm, poses in bimanual.items():
            inside = None
            if reference is not None:
                lo, hi = reference.min(0), reference.max(0)
                dims = slice(0, 3) if use_yaw and obj not in ("button", "rope_end", "ball") else slice(0, 2)
                inside = round(float(np.mean(np.all((poses[:, dims] >= lo[dims]) & (poses[:, dims] <= hi[dims]),
                                                    axis=1))), 3)
            rows.append(Coverage(task, obj, arm, single, _ranges(poses),
                                 _ranges(reference) if reference is not None else None, inside))
    return rows
