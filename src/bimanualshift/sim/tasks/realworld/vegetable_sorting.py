"""Vegetable sorting (the paper's real-world Coordination tier, 4 keyframes): both arms at once, each puts the
vegetable the instruction names for its side into the bin on its side. Four of five categories lie on the table,
two per side, so each arm must pick the named one beside a distractor; categories, colours, placements and the
bins' positions vary with the seed."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.placement import sample_separated
from bimanualshift.sim.props.vegetables import (
    BIN_FLOOR,
    BIN_HEIGHT,
    BIN_INNER_HALF,
    VEGETABLES,
    bin_xml,
    vegetable_xml,
)
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, Task, down_quat, register_task

CATEGORIES = tuple(VEGETABLES)
BINS = {"left": "bin_0", "right": "bin_1"}
SIDE = {"left": 1.0, "right": -1.0}
# per side (mirrored in y): where its two vegetables lie and where its bin stands
VEGETABLE_REGION = ((-0.12, 0.08), (0.04, 0.19))
BIN_REGION = ((0.0, 0.10), (0.34, 0.40))
PARKED = np.array([1.5, 0.0, 0.1])  # the category not in this episode waits off the table
CARRY_HEIGHT = 0.16  # above the table while carrying, clear of the bin walls
GRASP_BELOW_CENTRE, GRASP_CLEARANCE = 0.015, 0.016  # metres: where the gripper's site goes for a grasp


def _side_region(region: tuple[tuple[float, float], tuple[float, float]], side: float
                 ) -> tuple[tuple[float, float], tuple[float, float]]:
    (x0, x1), (y0, y1) = region
    return (x0, x1), ((y0, y1) if side > 0 else (-y1, -y0))


@register_task("vegetable_sorting")
class VegetableSorting(Task):
    bimanual = True
    tier = "Coordination"
    paper_keyframes = 4
    robot = "ur5e"

    def scene_xml(self) -> str:
        return "".join(vegetable_xml(c) for c in CATEGORIES) + "".join(bin_xml(b) for b in BINS.values())

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        chosen = [str(c) for c in rng.permutation(CATEGORIES)[:4]]  # left target, left distractor, right ...
        colours = self.pick_colours(rng, 4)
        for arm, s in SIDE.items():
            xy = _side_region(BIN_REGION, s)
            sim.model.body_pos[sim.body_id(BINS[arm])] = [rng.uniform(*xy[0]), rng.uniform(*xy[1]), TABLE_TOP_Z]
        regions = [_side_region(VEGETABLE_REGION, s) for s in (1.0, 1.0, -1.0, -1.0)]
        spots = sample_separated(rng, regions, min_distance=0.15)  # an open Robotiq spans 14 cm
        for category in CATEGORIES:
            if category not in chosen:
                sim.set_free_pose(f"{category}_joint", PARKED + [0.0, 0.2 * CATEGORIES.index(category), 0.0])
        for i, category in enumerate(chosen):
            # long axis within 45 degrees of the table's width: the fingers then close across the table's depth,
            # away from the bins and from the other side's vegetables
            yaw = rng.uniform(np.pi / 4, 3 * np.pi / 4)
            lying = Rotation.from_euler("z", yaw)
            half = VEGETABLES[category][2]
            sim.set_free_pose(f"{category}_joint", np.r_[spots[i], TABLE_TOP_Z + half + 0.001], lying.as_quat())
            sim.set_rgb(f"{category}_geom", self.palette[colours[i]])
        self.episode = {"targets": {"left": chosen[0], "right": chosen[2]}, "distractors": [chosen[1], chosen[3]],
                        "colours": dict(zip(chosen, colours))}

    def instruction(self) -> str:
        t = self.episode["targets"]
        return f"put the {t['left']} in the left bin and the {t['right']} in the right bin"

    def goal_nouns(self) -> list[str]:
        t = self.episode["targets"]
        return [t["left"], t["right"], "bin"]

    def in_bin(self, sim: SimHandle, category: str, arm: str) -> bool:
        return in_bin(sim, category, BINS[arm])

    def evaluate_success(self, sim: SimHandle) -> bool:
        return all(self.in_bin(sim, self.episode["targets"][arm], arm) for arm in SIDE)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {arm: [self.episode["targets"][arm], BINS[arm]] for arm in SIDE}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        # each job to the arm on its bin's side (a left-right exchange moves the bins, not the arms)
        plan = {}
        for job in SIDE:
            arm = "left" if sim.body_pos(BINS[job])[1] > 0 else "right"
            plan[arm] = place_keyframes(sim, self.episode["targets"][job], BINS[job])
        return [{arm: plan[arm][k] for arm in SIDE} for k in range(4)]


def in_bin(sim: SimHandle, body: str, bin_name: str) -> bool:
    """Whether ``body``'s centre is inside the bin's walls and below their rim."""
    pos, centre = sim.body_pos(body), sim.body_pos(bin_name)
    inside = np.all(np.abs(pos[:2] - centre[:2]) < BIN_INNER_HALF)
    return bool(inside and pos[2] < TABLE_TOP_Z + 2 * BIN_FLOOR + BIN_HEIGHT)


def place_keyframes(sim: SimHandle, body: str, bin_name: str) -> list[ArmAction]:
    """One arm's four keyframes: above the vegetable, down and close, over the bin, open (it drops in)."""
    pos = sim.body_pos(body)
    yaw = Rotation.from_matrix(sim.data.xmat[sim.body_id(body)].reshape(3, 3)).as_euler("xyz")[2]
    quat = down_quat(yaw)  # fingers close across the vegetable's long axis
    # the Robotiq's pads reach 7 cm above its site: the site just above the table puts the pads around the
    # vegetable's middle
    grasp = np.r_[pos[:2], max(pos[2] - GRASP_BELOW_CENTRE, TABLE_TOP_Z + GRASP_CLEARANCE)]
    above_bin = sim.body_pos(bin_name) + [0.0, 0.0, CARRY_HEIGHT]
    return [ArmAction(grasp + [0.0, 0.0, 0.10], quat, 1.0, 1.0), ArmAction(grasp, quat, 0.0, 0.0),
            ArmAction(above_bin, down_quat(0.0), 0.0, 1.0), ArmAction(above_bin, down_quat(0.0), 1.0, 1.0)]
