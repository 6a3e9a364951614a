"""Single arm, on the UR5e twin: pick up the block and thread it onto a rod mounted in the air (insert), the skill
of `block_threading`'s right arm. Block and rod lie where that task puts them from its right arm's base, on
either side: the block 8-16 cm out, the rod's tip 30-38 cm out at the height the other arm holds it."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z, skill_side
from bimanualshift.sim.props.threading import BLOCK_HALF, ROD_HALF_LENGTH, block_xml, rod_xml
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, register_task
from bimanualshift.sim.tasks.realworld.block_threading import (
    BEFORE_TIP,
    BLOCK_BELOW_SITE,
    GRIP_ABOVE_CENTRE,
    HOLD_HEIGHT,
    ONTO_ROD,
    TIP_BELOW_SITE,
    YAW,
    ThreadingTask,
    hand_down,
    shorter_turn,
    threading_stages,
)

BLOCK_X, BLOCK_Y = (-0.04, 0.06), (0.08, 0.16)  # |y| from the arm's base
TIP_X, TIP_Y = (-0.03, 0.07), (0.30, 0.38)


@register_task("thread_block")
class ThreadBlock(ThreadingTask):
    bimanual = False

    def scene_xml(self) -> str:
        return rod_xml("rod", mounted=True) + block_xml("block", wide=self.perturbations.unseen_shapes)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        side = skill_side(rng)
        block = np.array([rng.uniform(*BLOCK_X), side * rng.uniform(*BLOCK_Y)])
        yaws = rng.uniform(-YAW, YAW, size=2)
        sim.set_free_pose("block_joint", np.r_[block, TABLE_TOP_Z + BLOCK_HALF + 0.001],
                          Rotation.from_euler("z", yaws[0]).as_quat())
        # the mounted rod: its tip towards the arm, held where the other arm of block_threading holds it
        yaw = yaws[1] + (0.0 if side > 0 else np.pi)
        axis = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
        tip = np.array([rng.uniform(*TIP_X), side * rng.uniform(*TIP_Y), TABLE_TOP_Z + HOLD_HEIGHT - TIP_BELOW_SITE])
        rod = sim.body_id("rod")
        sim.model.body_pos[rod] = tip + ROD_HALF_LENGTH * axis
        sim.model.body_quat[rod] = np.roll(Rotation.from_euler("z", yaw).as_quat(), 1)
        self.paint(sim, rng)

    def evaluate_stages(self, sim: SimHandle) -> list[bool]:
        return threading_stages(sim, sim.body_pos("block")[2] - BLOCK_HALF > TABLE_TOP_Z + 0.05)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["block", "rod"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        block = sim.body_pos("block")
        block_yaw = Rotation.from_matrix(sim.data.xmat[sim.body_id("block")].reshape(3, 3)).as_euler("xyz")[2]
        mat = sim.data.xmat[sim.body_id("rod")].reshape(3, 3)
        along = mat[:, 1]
        tip = sim.body_pos("rod") - ROD_HALF_LENGTH * along
        rod_yaw = float(np.arctan2(-along[0], along[1]))
        grip = block + [0.0, 0.0, GRIP_ABOVE_CENTRE]
        up = np.array([0.0, 0.0, BLOCK_BELOW_SITE])
        level = hand_down(shorter_turn(rod_yaw + np.pi / 2, block_yaw + np.pi / 2))
        return [{"right": ArmAction(grip + [0, 0, 0.08], hand_down(block_yaw + np.pi / 2), 1.0, 1.0)},
                {"right": ArmAction(grip, hand_down(block_yaw + np.pi / 2), 0.0, 0.0)},
                {"right": ArmAction(tip - BEFORE_TIP * along + up, level, 0.0, 1.0)},
                {"right": ArmAction(tip + ONTO_ROD * along + up, level, 0.0, 0.0)}]
