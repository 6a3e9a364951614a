"""Single arm, on the UR5e twin: take a flower out of its stand by the bloom and put its stem into a vase (insert),
the skill of Flower Arrangement's right arm. The stand is 6-12 cm to the arm's left; the vase is fixed to the table
30-36 cm out on that side, as both stand from the right arm's base in that task. Success: the stem's foot inside
the vase below its rim."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.cups import cup_xml
from bimanualshift.sim.props.flowers import flower_xml, stand_xml
from bimanualshift.sim.task import Keyframe, SimHandle, register_task
from bimanualshift.sim.tasks.realworld.flower_arrangement import FlowerTask, insert_keyframes
from bimanualshift.sim.tasks.realworld.pouring_water import SOURCE_REGION, TARGET_REGION, YAW
from bimanualshift.sim.tasks.unimanual.pour_cup import FULL_Y, TARGET_Y


@register_task("insert_stem")
class InsertStem(FlowerTask):
    bimanual = False

    def scene_xml(self) -> str:
        return cup_xml("vase", mounted=True) + stand_xml() + flower_xml()

    def instruction(self) -> str:
        return "put the flower in the vase"

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        # both to the arm's left (+y): where Flower Arrangement's right arm works
        vase = sim.body_id("vase")
        sim.model.body_pos[vase] = (rng.uniform(*TARGET_REGION[0]), rng.uniform(*TARGET_Y), TABLE_TOP_Z)
        # the fixed vase's handle away from the arm, as the other arm holds it in that task
        sim.model.body_quat[vase] = np.roll(Rotation.from_euler("z", np.pi + rng.uniform(-YAW, YAW)).as_quat(), 1)
        self.place_flower(sim, np.array([rng.uniform(*SOURCE_REGION[0]), rng.uniform(*FULL_Y)]), rng)
        self.paint(sim, rng)

    def evaluate_success(self, sim: SimHandle) -> bool:
        return self.stem_in_vase(sim)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["flower", "vase"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in insert_keyframes(sim, "flower", "vase")]
