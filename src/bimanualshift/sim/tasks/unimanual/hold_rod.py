"""Single arm, on the UR5e twin: pick up the rod and hold it level in the air (hold and steady), the skill of
`block_threading`'s left arm. The rod lies 12-17 cm to either side of the arm, as that task's rod lies from its
left arm's base; the arm grips it near its middle and lifts it 15 cm."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z, skill_side
from bimanualshift.sim.props.threading import ROD_HALF_WIDTH, rod_xml
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, Task, register_task
from bimanualshift.sim.tasks.realworld.block_threading import YAW, rod_grip

ROD_X, ROD_Y = (-0.04, 0.06), (0.12, 0.17)  # |y| from the arm's base
LEVEL_WITHIN = np.sin(np.deg2rad(10.0))  # the rod's axis within 10 degrees of level
LIFTED_BY = 0.10


@register_task("hold_rod")
class HoldRod(Task):
    bimanual = False
    robot = "ur5e"

    def scene_xml(self) -> str:
        return rod_xml("rod", flat=self.perturbations.unseen_shapes)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        side = skill_side(rng)
        xy = np.array([rng.uniform(*ROD_X), side * rng.uniform(*ROD_Y)])
        yaw = rng.uniform(-YAW, YAW) + (0.0 if side < 0 else np.pi)  # its far end towards the arm's outside
        sim.set_free_pose("rod_joint", np.r_[xy, TABLE_TOP_Z + ROD_HALF_WIDTH + 0.001],
                          Rotation.from_euler("z", yaw).as_quat())
        colour = self.pick_colours(rng, 1)[0]
        sim.set_rgb("rod_geom", self.palette[colour])
        self.episode = {"colour": colour}

    def instruction(self) -> str:
        return "lift the rod level"

    def goal_nouns(self) -> list[str]:
        return ["rod"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        axis = sim.data.xmat[sim.body_id("rod")].reshape(3, 3)[:, 1]
        lifted = sim.body_pos("rod")[2] > TABLE_TOP_Z + ROD_HALF_WIDTH + LIFTED_BY
        return bool(lifted and abs(axis[2]) < LEVEL_WITHIN and sim.pinched("rod"))

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["rod"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        grip, quat, held, _ = rod_grip(sim)
        return [{"right": ArmAction(grip + [0, 0, 0.08], quat, 1.0, 1.0)},
                {"right": ArmAction(grip, quat, 0.0, 0.0)},
                {"right": ArmAction(held, quat, 0.0, 1.0)}]
