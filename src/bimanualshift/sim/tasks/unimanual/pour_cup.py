"""Single arm, on the UR5e twin: lift a cup full of water (40 balls) by its rim and pour it into another cup
(pour), the skill of Pouring Water's right arm. The full cup stands 6-12 cm to the arm's left, its handle
towards it; the other cup is fixed to the table 30-36 cm out on that side, as both stand from the right arm's
base in that task. Success: 70 % of the balls in the other cup at least."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.cups import cup_xml, water_in, water_xml
from bimanualshift.sim.task import Keyframe, SimHandle, register_task
from bimanualshift.sim.tasks.realworld.pouring_water import (
    POURED,
    SOURCE_REGION,
    TARGET_REGION,
    YAW,
    PouringTask,
    pour_keyframes,
)

FULL_Y = (0.06, 0.12)  # |y| from the arm's base
TARGET_Y = (0.30, 0.36)


@register_task("pour_cup")
class PourCup(PouringTask):
    bimanual = False

    def scene_xml(self) -> str:
        return cup_xml("cup_held", mounted=True) + cup_xml("cup_full") + water_xml()

    def instruction(self) -> str:
        return "pour the water into the other cup"

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        # both cups to the arm's left (+y): where Pouring Water's right arm pours (its left arm never does)
        full = np.array([rng.uniform(*SOURCE_REGION[0]), rng.uniform(*FULL_Y)])
        target = sim.body_id("cup_held")
        sim.model.body_pos[target] = (rng.uniform(*TARGET_REGION[0]), rng.uniform(*TARGET_Y), TABLE_TOP_Z)
        # the fixed cup's handle away from the arm
        sim.model.body_quat[target] = np.roll(Rotation.from_euler("z", np.pi + rng.uniform(-YAW, YAW)).as_quat(), 1)
        yaw = rng.uniform(-YAW, YAW)  # the full cup's handle towards the arm
        sim.set_free_pose("cup_full_joint", np.r_[full, TABLE_TOP_Z + 0.001], Rotation.from_euler("z", yaw).as_quat())
        self.fill_and_colour(sim, full, rng)

    def evaluate_success(self, sim: SimHandle) -> bool:
        return water_in(sim, "cup_held") >= POURED

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["cup_full", "cup_held"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in pour_keyframes(sim, "cup_full", "cup_held")]
