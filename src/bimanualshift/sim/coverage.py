"""Where the bimanual tasks put each arm's goal objects in that arm's own frame, against where the matching
single-arm pretraining task puts the same kind of object (its arm at y = 0).

A frozen single-arm prior serves either arm because observations and actions are expressed in the arm's base
frame; that works only where, in that frame, the single-arm data covers the bimanual layouts. Which objects an
arm acts on comes from the task (``Task.arm_goals``), and every pose from the tasks' own ``initialize_episode``
(an env reset per seed, nothing rendered), never from a declared table.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.props.rope import rope_ends
from bimanualshift.sim.props.vegetables import VEGETABLES

# Bimanual task -> {kind of goal object: the single-arm task acting on the same kind, or one per arm where the two
# arms do different things to it (one holds the toaster, the other presses its lever)}.
SKILL_PAIRS: dict[str, dict[str, str | dict[str, str]]] = {
    "push_two_buttons": {"button": "push_button"},
    "lift_ball": {"ball": "push_ball_aside"},
    "pick_up_plate": {"plate": "pick_up_small_plate"},
    "take_tray_out_of_oven": {"oven": "open_oven_door", "tray": "take_tray_out_of_open_oven"},
    "straighten_rope": {"rope_end": "pull_rope_end"},
    "sweep_to_dustpan": {"dustpan": "hold_dustpan", "brush": "sweep_dirt"},
    "buttons_then_lift_ball": {"button": "push_button", "ball": "push_ball_aside"},
    # the paper's real-world tasks on the UR5e twin, against the twin's single-arm skills
    "vegetable_sorting": {"vegetable": "place_vegetable", "bin": "place_vegetable"},
    "block_threading": {"rod": "hold_rod", "block": "thread_block"},
    "toaster_activation": {"toaster": {"left": "steady_toaster", "right": "press_lever"}},
    "toasting_completion": {"toaster": {"left": "steady_toaster", "right": "insert_bread"}, "bread": "insert_bread"},
    "pouring_water": {"cup": {"left": "hold_cup", "right": "pour_cup"}},
    # the vase is the pouring task's cup: held as `hold_cup` holds it, filled as `insert_stem` fills it
    "flower_arrangement": {"cup": {"left": "hold_cup", "right": "insert_stem"}, "flower": "insert_stem"},
    "quilt_folding": {"quilt_tab": "fold_corner"},
    "cable_routing": {"cable_plug": "route_cable", "clip": "route_cable"},
    "serve_toast": {"toaster": {"left": "steady_toaster", "right": "insert_bread"}, "bread": "insert_bread",
                    "plate": "place_toast"},
}


def single_arm_task(task: str, kind: str, arm: str) -> str:
    """The single-arm task whose data should cover ``arm``'s goals of ``kind`` in ``task``."""
    single = SKILL_PAIRS[task][kind]
    return single if isinstance(single, str) else single[arm]


def single_arm_tasks(task: str) -> set[str]:
    return {s for single in SKILL_PAIRS[task].values() for s in ([single] if isinstance(single, str)
                                                                  else single.values())}
# Kinds whose turn about the vertical the cameras cannot see (round) are compared by position only.
ROUND_KINDS = frozenset({"button", "plate", "ball", "rope_end"})
# Goal classes compared as one kind: the vegetables a hand grasps the same way (down, across the long axis)
KIND_ALIASES = {category: "vegetable" for category in VEGETABLES} | {"cup_held": "cup", "cup_full": "cup",
                                                                    "vase": "cup", "quilt_tab_left": "quilt_tab",
                                                                    "quilt_tab_right": "quilt_tab",
                                                                    "cable_plug_head": "cable_plug",
                                                                    "cable_plug_tail": "cable_plug",
                                                                    "clip_left": "clip", "clip_right": "clip"}
# A bimanual pose is covered when a single-arm sample lies this close (x, y in metres; yaw in radians).
NEAR_XY = 0.05
NEAR_YAW = 0.20


def goal_kind(goal: str) -> str:
    """``button_1`` -> ``button``, ``rope:head`` -> ``rope_end``."""
    if goal.startswith("rope:"):
        return "rope_end"
    kind = goal.rsplit("_", 1)[0] if goal[-1].isdigit() else goal
    return KIND_ALIASES.get(kind, kind)


def _yaw(quat_wxyz: np.ndarray) -> float:
    w, x, y, z = quat_wxyz
    return float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


def goal_pose(env: ManipulationEnv, goal: str) -> np.ndarray:
    """World x, y and yaw of one goal (a root body, or a rope end as ``rope:head`` / ``rope:tail``)."""
    if goal.startswith("rope:"):
        head, tail = rope_ends(env.sim, "rope")
        end = head if goal == "rope:head" else tail
        return np.array([end[0], end[1], 0.0])
    b = env.sim.body_id(goal)
    return np.array([*env.sim.data.xpos[b][:2], _yaw(env.sim.data.xquat[b])])


def arm_frame_goal_poses(task: str, seeds: list[int]) -> dict[str, dict[str, np.ndarray]]:
    """kind -> arm -> (n, 3) arm-frame x, y and yaw of that arm's goals of that kind over ``seeds``."""
    env = ManipulationEnv(task, image_size=32)
    out: dict[str, dict[str, list[np.ndarray]]] = {}
    for seed in seeds:
        env.reset(seed=seed, options={"render": False, "settle": False})
        goals = env.task.arm_goals(env.sim)
        if not goals:
            raise ValueError(f"task {task!r} declares no arm goals (Task.arm_goals): its coverage is unknown")
        for arm, names in goals.items():
            frame = env.arm_frames[arm]
            for name in names:
                x, y, yaw = goal_pose(env, name)
                local = frame.points_to_arm(np.array([[x, y, 0.0]]))[0]
                out.setdefault(goal_kind(name), {}).setdefault(arm, []).append(
                    np.array([local[0], local[1], wrap(yaw - frame.yaw)]))
    env.close()
    return {kind: {arm: np.stack(rows) for arm, rows in arms.items()} for kind, arms in out.items()}


def wrap(angle: float | np.ndarray) -> float | np.ndarray:
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def covered(poses: np.ndarray, reference: np.ndarray, use_yaw: bool) -> np.ndarray:
    """(n,) whether each pose has a reference sample within NEAR_XY (and NEAR_YAW when ``use_yaw``)."""
    dxy = np.linalg.norm(poses[:, None, :2] - reference[None, :, :2], axis=-1)
    near = dxy <= NEAR_XY
    if use_yaw:
        near &= np.abs(wrap(poses[:, None, 2] - reference[None, :, 2])) <= NEAR_YAW
    return near.any(axis=1)


@dataclass
class Coverage:
    """One bimanual (task, kind of goal object, arm) against its single-arm task: the range of each and the
    share of the bimanual poses with a single-arm sample nearby (x, y and, for oriented objects, yaw)."""

    task: str
    obj: str
    arm: str
    single_arm_task: str
    bimanual_range: list[list[float]]  # [[min, max]] for x, y, yaw
    single_arm_range: list[list[float]]
    inside: float  # share of bimanual poses with a single-arm sample within NEAR_XY / NEAR_YAW
    farthest_cm: float  # the worst bimanual pose's distance (x, y) to its nearest single-arm sample


def _ranges(poses: np.ndarray) -> list[list[float]]:
    return [[round(float(poses[:, i].min()), 3), round(float(poses[:, i].max()), 3)] for i in range(3)]


@functools.lru_cache(maxsize=32)
def _single_arm_poses(task: str, seeds: tuple[int, ...]) -> dict[str, dict[str, np.ndarray]]:
    """A single-arm task's goal poses, computed once per process: several bimanual tasks share one skill."""
    return arm_frame_goal_poses(task, list(seeds))


def coverage(task: str, seeds: list[int], single_arm_seeds: list[int]) -> list[Coverage]:
    bimanual = arm_frame_goal_poses(task, seeds)
    rows = []
    for kind in SKILL_PAIRS[task]:
        for arm, poses in sorted(bimanual[kind].items()):
            single = single_arm_task(task, kind, arm)
            reference = _single_arm_poses(single, tuple(single_arm_seeds))[kind]["right"]
            inside = covered(poses, reference, kind not in ROUND_KINDS)
            gaps = np.linalg.norm(poses[:, None, :2] - reference[None, :, :2], axis=-1).min(axis=1)
            rows.append(Coverage(task, kind, arm, single, _ranges(poses), _ranges(reference),
                                 round(float(inside.mean()), 3), round(float(gaps.max()) * 100, 1)))
    return rows
