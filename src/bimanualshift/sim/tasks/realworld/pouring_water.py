"""Pouring water (the paper's real-world Collaboration tier, 4 keyframes): the left arm holds a cup by its handle;
the right arm takes the other cup, full of 40 small balls standing in for water, by its handle, brings it over the
held cup and tips it. Success: at least 70 % of the balls in the held cup, and that cup held upright."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
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
from bimanualshift.sim.tasks.realworld.block_threading import hand_down, shorter_turn

TARGET_REGION = ((-0.06, 0.04), (0.0, 0.06))
SOURCE_REGION = ((-0.04, 0.04), (-0.24, -0.18))
YAW = np.pi / 16
POURED = 0.70  # the share of the balls that must end in the held cup
TILT = np.deg2rad(110.0)  # how far the pouring hand turns its cup
LIP_ABOVE_RIM = 0.04  # the pouring lip this far above the held cup's rim
CARRY_BESIDE_POUR = 0.07  # the full cup is carried upright this far beside where it pours
HANDLE_GRIP_OUT = 0.04  # the hand grips a handle this far out from the cup's wall
GRIP_BELOW_HANDLE_TOP = 0.012


def across(yaw: float) -> float:
    """The hand's yaw for fingers closing across a handle turned by ``yaw``, the nearer way round."""
    return shorter_turn(yaw + np.pi / 2, np.pi / 2)


def handle_local() -> np.ndarray:
    """Where a hand grips a cup's handle, in the cup's frame."""
    return np.array([0.0, -(CUP_RADIUS + CUP_WALL + HANDLE_GRIP_OUT), CUP_HEIGHT - 0.01 - GRIP_BELOW_HANDLE_TOP])


def handle_keyframes(sim: SimHandle, cup: str) -> tuple[ArmAction, ArmAction]:
    grip = to_world(sim, cup, handle_local())
    quat = hand_down(across(yaw_of(sim, cup)))
    return ArmAction(grip + [0, 0, 0.08], quat, 1.0, 1.0), ArmAction(grip, quat, 0.0, 0.0)


def pour_keyframes(sim: SimHandle, source: str, target: str) -> list[ArmAction]:
    """Over the held cup with the full one upright, then turned by ``TILT`` about its handle's axis, as a hand pours
    from a mug, so that its lip ends ``LIP_ABOVE_RIM`` above the held cup's mouth. It is turned the way that tips
    its mouth towards the robots: the hand then ends pointing forward, a pose the arm reaches from either side."""
    approach, grip = handle_keyframes(sim, source)
    mouth = to_world(sim, target, [0.0, 0.0, CUP_HEIGHT])
    # the full cup hangs from the hand towards the held one: its handle's axis along the line between them
    heading = float(np.arctan2(mouth[1] - grip.position[1], mouth[0] - grip.position[0]))
    yaw = heading - np.pi / 2
    turn = Rotation.from_euler("z", yaw)
    side = 1.0 if turn.apply([1.0, 0.0, 0.0])[0] < 0 else -1.0  # the cup's own x that points at the robots
    tipped = Rotation.from_rotvec(side * TILT * turn.apply([0.0, 1.0, 0.0]))
    lip_from_grip = np.array([side * CUP_RADIUS, 0.0, CUP_HEIGHT]) - handle_local()
    # where the hand goes so that the tipped cup's lip is over the held cup's mouth
    pour_at = mouth + [0.0, 0.0, LIP_ABOVE_RIM] - tipped.apply(turn.apply(lip_from_grip))
    upright = hand_down(across(yaw))
    tipped_hand = (tipped * Rotation.from_quat(upright)).as_quat()
    # carried upright beside the pour, away from the way it tips, its floor clear of the held cup's rim; it tips
    # over the held cup as the hand moves in
    tip_towards = turn.apply([side, 0.0, 0.0])
    carry = pour_at - CARRY_BESIDE_POUR * tip_towards + [0.0, 0.0, 0.02]
    return [approach, grip, ArmAction(carry, upright, 0.0, 1.0), ArmAction(pour_at, tipped_hand, 0.0, 1.0)]


class PouringTask(Task):
    """What the pouring tasks share: the robot, the instruction and the success measure."""

    robot = "ur5e"
    mirrored_by_half_turn = ("cup_full", "cup_held")  # a cup's mirror image has its handle on the other side

    def instruction(self) -> str:
        return "hold the cup and pour the water into it"

    def goal_nouns(self) -> list[str]:
        return ["cup", "water"]

    def instance_class(self, instance: str) -> str:
        return "cup" if instance.startswith("cup_") else "water" if instance.startswith("water_") else instance


@register_task("pouring_water")
class PouringWater(PouringTask):
    bimanual = True

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
        fill_cup(sim, full, rng)
        held_colour, full_colour = self.pick_colours(rng, 2)
        sim.set_rgb_prefix("cup_held_", self.palette[held_colour])
        sim.set_rgb_prefix("cup_full_", self.palette[full_colour])
        self.episode = {"colours": {"cup_held": held_colour, "cup_full": full_colour}}

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
    return ("left", "right") if sim.body_pos("cup_held")[1] > sim.body_pos("cup_full")[1] else ("right", "left")

