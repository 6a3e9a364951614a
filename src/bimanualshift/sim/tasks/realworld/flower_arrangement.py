"""Flower arrangement (the paper's real-world Collaboration tier, 5 keyframes): the left arm holds a vase steady by
its handle; the right arm takes a flower by its bloom out of its stand, carries it over the vase and lowers its
stem in. Success: the stem's foot inside the vase below its rim, the vase held, upright and where it stood.

The vase is the pouring task's cup (handle towards the arm that holds it), so the hold is the same skill
(`hold_cup`); the flower is put in by `insert_stem`."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z, arms_by_side
from bimanualshift.sim.props.cups import CUP_FLOOR, CUP_HEIGHT, cup_xml, in_cup
from bimanualshift.sim.props.flowers import BLOOM_CENTRE, STAND_HEIGHT, flower_xml, stand_xml
from bimanualshift.sim.props.toaster import yaw_of
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, Task, register_task
from bimanualshift.sim.tasks.realworld.block_threading import across, grasp_from_above, hand_down
from bimanualshift.sim.tasks.realworld.pouring_water import SOURCE_REGION, TARGET_REGION, YAW, handle_keyframes

LIFT_ABOVE_STAND = 0.04  # the stem's foot lifted this far above the stand's walls
OVER_RIM = 0.03  # carried over the vase with its foot this far above the rim
INTO_VASE = 0.025  # lowered until its foot is this far above the vase's floor
STILL_WITHIN = 0.03  # the vase moved by at most this (metres) and tipped by at most UPRIGHT
UPRIGHT = np.deg2rad(15.0)


def flower_grip(sim: SimHandle, flower: str = "flower") -> tuple[np.ndarray, np.ndarray]:
    """Where a hand takes the flower (the bloom's centre: the pads cover its sides) and how it is turned
    (pointing down, fingers closing across two of the bloom's faces, whichever way round is nearer the hand's
    own)."""
    grip = sim.body_pos(flower) + [0.0, 0.0, BLOOM_CENTRE]
    return grip, hand_down(across(yaw_of(sim, flower)))


def insert_keyframes(sim: SimHandle, flower: str, vase: str) -> list[ArmAction]:
    """Above the bloom, closed on it, lifted straight out of the stand, over the vase's mouth, lowered in."""
    grip, quat = flower_grip(sim, flower)
    foot_to_grip = grip - sim.body_pos(flower)  # the stem hangs straight below the hand
    lifted = grip.copy()
    lifted[2] = TABLE_TOP_Z + STAND_HEIGHT + LIFT_ABOVE_STAND + foot_to_grip[2]
    mouth = sim.body_pos(vase)
    over = np.r_[mouth[:2], mouth[2] + CUP_HEIGHT + OVER_RIM + foot_to_grip[2]]
    lifted[2] = max(lifted[2], over[2])  # out of the stand and clear of the rim before it moves sideways
    inserted = np.r_[mouth[:2], mouth[2] + CUP_FLOOR + INTO_VASE + foot_to_grip[2]]
    return [*grasp_from_above(grip, quat), ArmAction(lifted, quat, 0.0, 1.0), ArmAction(over, quat, 0.0, 1.0),
            ArmAction(inserted, quat, 0.0, 0.0)]


class FlowerTask(Task):
    """What the flower tasks share: the robot, the instruction, the nouns and the colours."""

    robot = "ur5e"

    def instruction(self) -> str:
        return "hold the vase and put the flower in it"

    def goal_nouns(self) -> list[str]:
        return ["vase", "flower"]

    def paint(self, sim: SimHandle, rng: np.random.Generator) -> None:
        vase, bloom = self.pick_colours(rng, 2)
        sim.set_rgb_prefix("vase_", self.palette[vase])
        sim.set_rgb("flower_bloom", self.palette[bloom])
        self.episode = {**getattr(self, "episode", {}), "colours": {"vase": vase, "bloom": bloom}}

    def place_flower(self, sim: SimHandle, xy: np.ndarray, rng: np.random.Generator) -> None:
        """The stand fixed at ``xy`` and the flower upright in it, both turned by up to ``YAW``."""
        yaw = rng.uniform(-YAW, YAW)
        stand = sim.body_id("stand")
        sim.model.body_pos[stand] = (*xy, TABLE_TOP_Z)
        sim.model.body_quat[stand] = np.roll(Rotation.from_euler("z", yaw).as_quat(), 1)
        sim.set_free_pose("flower_joint", np.r_[xy, TABLE_TOP_Z + 0.001], Rotation.from_euler("z", yaw).as_quat())

    def stem_in_vase(self, sim: SimHandle) -> bool:
        return in_cup(sim, "vase", sim.body_pos("flower"))


@register_task("flower_arrangement")
class FlowerArrangement(FlowerTask):
    bimanual = True
    tier = "Collaboration"
    paper_keyframes = 5
    mirrored_by_half_turn = ("vase",)  # its mirror image has the handle on the other side

    def scene_xml(self) -> str:
        return cup_xml("vase") + stand_xml() + flower_xml()

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        vase = np.array([rng.uniform(*TARGET_REGION[0]), rng.uniform(*TARGET_REGION[1])])
        # the handle (on the cup's -y side) towards the left arm, which holds the vase
        sim.set_free_pose("vase_joint", np.r_[vase, TABLE_TOP_Z + 0.001],
                          Rotation.from_euler("z", np.pi + rng.uniform(-YAW, YAW)).as_quat())
        self.place_flower(sim, np.array([rng.uniform(*SOURCE_REGION[0]), rng.uniform(*SOURCE_REGION[1])]), rng)
        self.episode = {"vase_start": vase.tolist()}
        self.paint(sim, rng)

    def evaluate_success(self, sim: SimHandle) -> bool:
        up = sim.data.xmat[sim.body_id("vase")].reshape(3, 3)[2, 2]
        moved = np.linalg.norm(sim.body_pos("vase")[:2] - np.asarray(self.episode["vase_start"]))
        return bool(self.stem_in_vase(sim) and sim.pinched("vase") and moved < STILL_WITHIN and up > np.cos(UPRIGHT))

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        holder, inserter = vase_roles(sim)
        return {holder: ["vase"], inserter: ["flower", "vase"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        holder, inserter = vase_roles(sim)
        approach, grip = handle_keyframes(sim, "vase")
        hold = [approach, grip, grip, grip, grip]
        put = insert_keyframes(sim, "flower", "vase")
        return [{holder: h, inserter: p} for h, p in zip(hold, put, strict=True)]


def vase_roles(sim: SimHandle) -> tuple[str, str]:
    """(the arm that holds the vase, the arm that puts the flower in): each takes what stands on its side."""
    return arms_by_side(sim.body_pos("vase")[1], sim.body_pos("flower")[1])
