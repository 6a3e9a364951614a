"""Block threading (the paper's real-world Precision tier, 4 keyframes; its Table III): the left arm picks up a
square rod and holds it level in the air, pointing at the right arm; the right arm picks up a block with a square
hole and threads it onto the rod's free end. Three stages: approach (both lifted, the block before the rod's
tip), alignment (the hole on the rod's axis at its tip) and insertion (the block slid onto the rod).

The expert's plan is made from the first observation, so it carries how the objects settle in the Robotiq's
hands, measured once (the constants below); it threads the block on 99 of 100 test seeds."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.threading import (
    BLOCK_HALF,
    BLOCK_HALF_THICKNESS,
    HOLE_HALF,
    ROD_HALF_LENGTH,
    ROD_HALF_WIDTH,
    block_xml,
    rod_xml,
)
from bimanualshift.sim.task import DOWN_QUAT, ArmAction, Keyframe, SimHandle, Task, register_task

ROD_REGION = ((-0.04, 0.06), (0.13, 0.18))  # the rod's centre; it lies along y, its free end towards -y
BLOCK_REGION = ((-0.04, 0.06), (-0.22, -0.14))
YAW = np.pi / 16  # either object may lie turned by up to this much
HOLD_HEIGHT = 0.15  # above the table: where the rod is held (in the front camera's view)
ROD_GRIP_FROM_END = 0.075  # the left hand grips the rod this far from its far (+y) end, near its middle
SITE_BELOW_AXIS = 0.012  # the Robotiq's site this far below the middle of what it grips
SITE_ABOVE_TABLE = 0.016  # and never lower: its fingertips reach below the site
GRIP_ABOVE_CENTRE = 0.01  # where the right hand grips the block's sides: its site this far above the centre
# How the objects hang in the hands once lifted (measured over 20 seeds, std under 5 mm): the block's centre
# 2.7 cm below the right site (it settles in the pads); the rod's tip 0.8 cm below the left site (it sags).
# The rod also settles 1.0 cm to the hand's side across it and slips 0.6 cm towards its tip (std 3 mm).
BLOCK_BELOW_SITE = 0.027
TIP_BELOW_SITE = 0.008
TIP_ACROSS, TIP_ALONG = -0.010, -0.006  # in the rod's frame: along its own x, and along its axis (+: to the far end)
BEFORE_TIP = 0.05  # alignment: the hole's centre this far before the rod's tip
ONTO_ROD = 0.08  # insertion: pushed this far past the tip (it stops short, where the two arms' springs balance)
ALIGNED_WITHIN = 0.012  # the hole's centre off the rod's axis by at most this (metres)
# threaded: the rod's tip out through the block's far face by half a centimetre at least
INSERTED_BY = BLOCK_HALF_THICKNESS + 0.005


def rod_axis(sim: SimHandle) -> tuple[np.ndarray, np.ndarray]:
    """The rod's tip (its end nearer the block) and its unit axis pointing from the tip along the rod."""
    along = sim.data.xmat[sim.body_id("rod")].reshape(3, 3)[:, 1]  # the rod's own y
    centre, block = sim.body_pos("rod"), sim.body_pos("block")
    ends = [centre - ROD_HALF_LENGTH * along, centre + ROD_HALF_LENGTH * along]
    tip = min(ends, key=lambda end: float(np.linalg.norm(end - block)))
    return tip, (centre - tip) / ROD_HALF_LENGTH


def block_on_axis(sim: SimHandle) -> tuple[float, float]:
    """(how far the block's centre is off the rod's axis across the square hole's sides, the larger of the two,
    and how far past the tip along the axis)."""
    tip, axis = rod_axis(sim)
    offset = sim.body_pos("block") - tip
    along = float(offset @ axis)
    mat = sim.data.xmat[sim.body_id("block")].reshape(3, 3)
    across = offset - along * axis
    return float(max(abs(across @ mat[:, 0]), abs(across @ mat[:, 2]))), along


def threading_stages(sim: SimHandle, lifted: bool) -> list[bool]:
    """Approach, alignment and insertion of the block on the rod (``lifted``: what approach needs besides)."""
    off_axis, along = block_on_axis(sim)
    approach = lifted and -3 * BEFORE_TIP < along < ROD_HALF_LENGTH and off_axis < 0.05
    aligned = approach and off_axis < ALIGNED_WITHIN
    # threaded: the rod through the hole, touching its edge at most (the hole's clearance, plus contact softness);
    # not held to the alignment stage's tighter bound, which a rod resting on the hole's edge can exceed
    inserted = approach and along > INSERTED_BY and off_axis < HOLE_HALF - ROD_HALF_WIDTH + 0.002
    return [bool(approach), bool(aligned), bool(inserted)]


def shorter_turn(yaw: float, held: float) -> float:
    """``yaw`` or ``yaw`` plus whole half turns, whichever is nearest ``held``: the block's hole is the same either
    way round, so the hand holding it turns the shorter way."""
    return min((yaw + k * np.pi for k in range(-3, 4)), key=lambda y: abs(y - held))


def hand_down(yaw: float) -> np.ndarray:
    """The gripper pointing down, turned by ``yaw`` (not wrapped, unlike ``down_quat``: the Robotiq holds an
    object a little off its centre line, so a hand turned half a turn would hold it on the other side)."""
    q = (Rotation.from_euler("z", yaw) * Rotation.from_quat(DOWN_QUAT)).as_quat()
    return q if q[3] >= 0 else -q


def across(yaw: float) -> float:
    """The hand's yaw for fingers closing across something turned by ``yaw`` (a handle, a lever, a slice):
    whichever of the two ways round is nearer the hand's own, so an object turned round costs no half turn."""
    return shorter_turn(yaw + np.pi / 2, np.pi / 2)


def grasp_from_above(grip: np.ndarray, quat: np.ndarray) -> list[ArmAction]:
    """Open, 8 cm above ``grip``; then closed on it (collisions checked once the fingers are down)."""
    return [ArmAction(grip + [0, 0, 0.08], quat, 1.0, 1.0), ArmAction(grip, quat, 0.0, 0.0)]


def rod_grip(sim: SimHandle, away: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Where a hand grips the rod lying on the table (near its middle, towards its end on the ``away`` side of
    the table's centre line, +1 left, -1 right; fingers across it), how it is turned, where it holds the rod
    up, and the yaw of the rod's direction towards that end."""
    rod = sim.body_pos("rod")
    along = sim.data.xmat[sim.body_id("rod")].reshape(3, 3)[:, 1]
    along = along if along[1] * away >= 0 else -along
    yaw = float(np.arctan2(-along[0], along[1]))
    grip = rod + (ROD_HALF_LENGTH - ROD_GRIP_FROM_END) * np.array([-np.sin(yaw), np.cos(yaw), 0.0])
    grip[2] = max(rod[2] - SITE_BELOW_AXIS, TABLE_TOP_Z + SITE_ABOVE_TABLE)
    return grip, hand_down(yaw + np.pi / 2), np.r_[grip[:2], TABLE_TOP_Z + HOLD_HEIGHT], yaw


class ThreadingTask(Task):
    """What the threading tasks share: the instruction, the goal nouns, the colours and the three stages."""

    robot = "ur5e"
    stage_names = ("approach", "alignment", "insertion")

    def paint(self, sim: SimHandle, rng: np.random.Generator) -> None:
        rod_colour, block_colour = self.pick_colours(rng, 2)
        sim.set_rgb("rod_geom", self.palette[rod_colour])
        sim.set_rgb_prefix("block_bar", self.palette[block_colour])
        self.episode = {"colours": {"rod": rod_colour, "block": block_colour}}

    def instruction(self) -> str:
        return "thread the block onto the rod"

    def goal_nouns(self) -> list[str]:
        return ["block", "rod"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        return self.evaluate_stages(sim)[-1]


@register_task("block_threading")
class BlockThreading(ThreadingTask):
    bimanual = True
    tier = "Precision"
    paper_keyframes = 4

    def scene_xml(self) -> str:
        unseen = self.perturbations.unseen_shapes
        return rod_xml("rod", flat=unseen) + block_xml("block", wide=unseen)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        rod = np.array([rng.uniform(*ROD_REGION[0]), rng.uniform(*ROD_REGION[1])])
        block = np.array([rng.uniform(*BLOCK_REGION[0]), rng.uniform(*BLOCK_REGION[1])])
        yaws = rng.uniform(-YAW, YAW, size=2)
        sim.set_free_pose("rod_joint", np.r_[rod, TABLE_TOP_Z + ROD_HALF_WIDTH + 0.001],
                          Rotation.from_euler("z", yaws[0]).as_quat())
        sim.set_free_pose("block_joint", np.r_[block, TABLE_TOP_Z + BLOCK_HALF + 0.001],
                          Rotation.from_euler("z", yaws[1]).as_quat())
        self.paint(sim, rng)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        # what each arm picks up (the right arm threads onto the rod once the left holds it up: its skill,
        # thread_block, has the rod mounted there)
        return {"left": ["rod"], "right": ["block"]}

    # ---- judging -----------------------------------------------------------------------------------------------
    def _block_on_axis(self, sim: SimHandle) -> tuple[float, float]:
        return block_on_axis(sim)

    def evaluate_stages(self, sim: SimHandle) -> list[bool]:
        lifted = min(sim.body_pos("rod")[2], sim.body_pos("block")[2] - BLOCK_HALF) > TABLE_TOP_Z + 0.05
        return threading_stages(sim, lifted)

    # ---- the scripted expert ----------------------------------------------------------------------------------
    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        block = sim.body_pos("block")
        block_yaw = Rotation.from_matrix(sim.data.xmat[sim.body_id("block")].reshape(3, 3)).as_euler("xyz")[2]
        # The arm on the rod's side holds it (the left one, unless a left-right exchange put the rod on the right),
        # gripping it near its middle, fingers across it, its tip towards the other arm, which threads the block.
        away = 1.0 if sim.body_pos("rod")[1] > 0 else -1.0
        holder, threader = ("left", "right") if away > 0 else ("right", "left")
        grip, hold_quat, held_grip, rod_yaw = rod_grip(sim, away)
        along_rod = np.array([-np.sin(rod_yaw), np.cos(rod_yaw), 0.0])
        held_axis_z = held_grip[2] - TIP_BELOW_SITE
        across = np.array([np.cos(rod_yaw), np.sin(rod_yaw), 0.0])
        tip = np.r_[held_grip[:2] - (2 * ROD_HALF_LENGTH - ROD_GRIP_FROM_END) * along_rod[:2], held_axis_z]
        tip = tip + TIP_ACROSS * across + TIP_ALONG * along_rod
        # right: grip the block by its sides, fingers closing across the hole's axis, so that neither finger
        # stands in the rod's way; the site a little above the hole's centre
        thread_quat = hand_down(block_yaw + np.pi / 2)
        grip_r = block + [0.0, 0.0, GRIP_ABOVE_CENTRE]
        aligned = tip - BEFORE_TIP * along_rod + [0.0, 0.0, BLOCK_BELOW_SITE]
        threaded = tip + ONTO_ROD * along_rod + [0.0, 0.0, BLOCK_BELOW_SITE]
        level = hand_down(shorter_turn(rod_yaw + np.pi / 2, block_yaw + np.pi / 2))  # the hole along the rod
        plan = [
            (ArmAction(grip + [0, 0, 0.08], hold_quat, 1.0, 1.0),
             ArmAction(grip_r + [0, 0, 0.08], thread_quat, 1.0, 1.0)),
            (ArmAction(grip, hold_quat, 0.0, 0.0), ArmAction(grip_r, thread_quat, 0.0, 0.0)),
            (ArmAction(held_grip, hold_quat, 0.0, 1.0), ArmAction(aligned, level, 0.0, 1.0)),
            (ArmAction(held_grip, hold_quat, 0.0, 1.0), ArmAction(threaded, level, 0.0, 0.0)),
        ]
        return [{holder: hold, threader: thread} for hold, thread in plan]
