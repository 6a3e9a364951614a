"""Pouring water (the paper's real-world Collaboration tier, 4 keyframes): the left arm holds a cup by its handle;
the right arm pinches the other cup's rim, the cup full of 40 small balls standing in for water, lifts it over the
held cup and tips it towards the robots. Success: at least 70 % of the balls in the held cup, and that cup upright.
The held cup's handle sticks out 9 cm, so the hand holding it stays clear of the tipped cup."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z, arms_by_side
from bimanualshift.sim.props.cups import (
    CUP_HEIGHT,
    CUP_RADIUS,
    CUP_WALL,
    cup_xml,
    fill_cup,
    water_in,
    water_xml,
)
from bimanualshift.sim.props.toaster import to_world, yaw_of
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, Task, register_task
from bimanualshift.sim.tasks.realworld.block_threading import across, grasp_from_above, hand_down

TARGET_REGION = ((-0.06, 0.04), (0.0, 0.06))
SOURCE_REGION = ((-0.04, 0.04), (-0.24, -0.18))
YAW = np.pi / 16
POURED = 0.70  # the share of the balls that must end in the held cup
# How far the pouring hand tips its cup, and its lowest lip's height above the held rim: the wrist lags 2-5 degrees
# about the vertical, so the stream drifts sideways; tipped less, from lower, it lands (10 of 10 seeds against 6 at
# 110 degrees from 4 cm)
TILT = np.deg2rad(100.0)
LIP_ABOVE_RIM = 0.02
CARRY_BESIDE_POUR = 0.07  # the full cup is carried upright this far beside where it pours
CARRY_ABOVE_RIM = 0.12  # the carried cup's floor this high above the held rim: its path up from the table clears it
HANDLE_GRIP_OUT = 0.07  # the hand grips a handle this far out from the cup's wall: clear of the tipped cup
GRIP_BELOW_HANDLE_TOP = 0.012
RIM_PINCH_DEPTH = 0.035  # the pads' centre this far below the rim


def handle_local() -> np.ndarray:
    """Where a hand grips a cup's handle, in the cup's frame."""
    return np.array([0.0, -(CUP_RADIUS + CUP_WALL + HANDLE_GRIP_OUT), CUP_HEIGHT - 0.01 - GRIP_BELOW_HANDLE_TOP])


def handle_keyframes(sim: SimHandle, cup: str) -> list[ArmAction]:
    """Above the cup's handle, then the fingers closed across it."""
    return grasp_from_above(to_world(sim, cup, handle_local()), hand_down(across(yaw_of(sim, cup))))


def rim_pinch(sim: SimHandle, cup: str) -> tuple[np.ndarray, np.ndarray]:
    """Where a hand pinches the cup's rim on its far side (+x, away from the robots), one finger inside the wall and
    one outside, and how it is turned (pointing down, closing along the table's x). A cup held up by its handle
    turns in the fingers (its weight, 9 cm out, twists it about the fingers' axis: 55 degrees); held by the wall,
    the pads clamp the wall flat, so the cup turns only with the hand."""
    centre = sim.body_pos(cup)
    grip = np.array([centre[0] + CUP_RADIUS + CUP_WALL / 2, centre[1], centre[2] + CUP_HEIGHT - RIM_PINCH_DEPTH])
    return grip, hand_down(np.pi / 2)


def pour_keyframes(sim: SimHandle, source: str, target: str) -> list[ArmAction]:
    """Pinch the full cup's far rim, carry it upright beside the held cup, then tip it towards the robots (about
    the table's y axis through the pinch, the hand turning from pointing down to pointing forward and up) so that
    its lowest lip ends ``LIP_ABOVE_RIM`` above the held cup's mouth."""
    grip, quat = rim_pinch(sim, source)
    cup_from_grip = sim.body_pos(source) - grip  # the cup's origin from the pinch (the cup upright)
    mouth = to_world(sim, target, [0.0, 0.0, CUP_HEIGHT])
    tip = Rotation.from_rotvec([0.0, -TILT, 0.0])  # the cup's mouth turns towards -x, the robots
    rim = [np.array([CUP_RADIUS * np.cos(a), CUP_RADIUS * np.sin(a), CUP_HEIGHT])
           for a in np.linspace(0, 2 * np.pi, 48, endpoint=False)]
    lip = min(rim, key=lambda r: tip.apply(r)[2])  # the rim's lowest point once tipped (the cup's own yaw aside)
    pour_at = mouth + [0.0, 0.0, LIP_ABOVE_RIM] - tip.apply(cup_from_grip) - tip.apply(lip)
    tipped_hand = (tip * Rotation.from_quat(quat)).as_quat()
    # carried upright beside the pour, on the far side from where the mouth tips, its floor clear of the held rim
    carry = pour_at + [CARRY_BESIDE_POUR, 0.0, 0.0]
    carry[2] = max(pour_at[2], mouth[2] + CARRY_ABOVE_RIM - cup_from_grip[2])
    return [*grasp_from_above(grip, quat), ArmAction(carry, quat, 0.0, 1.0), ArmAction(pour_at, tipped_hand, 0.0, 1.0)]


class PouringTask(Task):
    """What the pouring tasks share: the robot, the instruction and the success measure."""

    robot = "ur5e"
    mirrored_by_half_turn = ("cup_full", "cup_held")  # a cup's mirror image has its handle on the other side
    hold_steps = 16  # 0.8 s: the balls leave the tipped cup and land before the next keyframe (or the end)
    particle_prefix = "water_"

    def instruction(self) -> str:
        return "hold the cup and pour the water into it"

    def goal_nouns(self) -> list[str]:
        return ["cup", "water"]

    def fill_and_colour(self, sim: SimHandle, full: np.ndarray, rng: np.random.Generator) -> None:
        """The water into the cup standing at ``full`` (x, y), and a colour for each cup."""
        fill_cup(sim, full, rng)
        held_colour, full_colour = self.pick_colours(rng, 2)
        sim.set_rgb_prefix("cup_held_", self.palette[held_colour])
        sim.set_rgb_prefix("cup_full_", self.palette[full_colour])
        self.episode = {"colours": {"cup_held": held_colour, "cup_full": full_colour}}

    def instance_class(self, instance: str) -> str:
        return "cup" if instance.startswith("cup_") else "water" if instance.startswith("water_") else instance


@register_task("pouring_water")
class PouringWater(PouringTask):
    bimanual = True
    tier = "Collaboration"
    paper_keyframes = 4

    def scene_xml(self) -> str:
        return cup_xml("cup_held") + cup_xml("cup_full") + water_xml()

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        held = np.array([rng.uniform(*TARGET_REGION[0]), rng.uniform(*TARGET_REGION[1])])
        full = np.array([rng.uniform(*SOURCE_REGION[0]), rng.uniform(*SOURCE_REGION[1])])
        # handles towards the arm that takes each cup: the held cup's towards the left arm, the full one's right
        sim.set_free_pose("cup_held_joint", np.r_[held, TABLE_TOP_Z + 0.001],
                          Rotation.from_euler("z", np.pi + rng.uniform(-YAW, YAW)).as_quat())
        sim.set_free_pose("cup_full_joint", np.r_[full, TABLE_TOP_Z + 0.001],
                          Rotation.from_euler("z", rng.uniform(-YAW, YAW)).as_quat())
        self.fill_and_colour(sim, full, rng)

    def evaluate_success(self, sim: SimHandle) -> bool:
        up = sim.data.xmat[sim.body_id("cup_held")].reshape(3, 3)[2, 2]
        return bool(water_in(sim, "cup_held") >= POURED and up > np.cos(np.deg2rad(20.0)))

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        holder, pourer = cup_roles(sim)
        return {holder: ["cup_held"], pourer: ["cup_full", "cup_held"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        holder, pourer = cup_roles(sim)
        approach, grip = handle_keyframes(sim, "cup_held")
        hold = [approach, grip, grip, grip]
        return [{holder: h, pourer: p} for h, p in zip(hold, pour_keyframes(sim, "cup_full", "cup_held"), strict=True)]


def cup_roles(sim: SimHandle) -> tuple[str, str]:
    """(the arm that holds the empty cup, the arm that pours): each takes the cup on its side."""
    return arms_by_side(sim.body_pos("cup_held")[1], sim.body_pos("cup_full")[1])

