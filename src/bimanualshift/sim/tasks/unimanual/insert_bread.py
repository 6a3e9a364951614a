"""Single arm, on the UR5e twin: take the slice of bread from its rack and put it into the toaster's slot
(insert), the skill of Toasting Completion's right arm. The toaster is fixed to the table 32-37 cm to either side
of the arm and the rack stands 4-10 cm out on the same side, as both stand from the right arm's base in the
toaster tasks."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import skill_side
from bimanualshift.sim.props.toaster import (
    bread_in_slot,
    bread_xml,
    place_bread_in_rack,
    place_toaster,
    rack_xml,
    toaster_xml,
)
from bimanualshift.sim.task import Keyframe, SimHandle, register_task
from bimanualshift.sim.tasks.realworld.toaster_scene import (
    RACK_REGION,
    TOASTER_REGION,
    WORKER_RACK_Y,
    WORKER_TOASTER_Y,
    YAW,
    ToasterTask,
    facing_yaw,
    insert_keyframes,
    sample_xy,
)


@register_task("insert_bread")
class InsertBread(ToasterTask):
    bimanual = False
    toaster_mounted = True

    def scene_xml(self) -> str:
        return toaster_xml("toaster", mounted=True) + rack_xml("rack") + bread_xml("bread")

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        side = skill_side(rng)
        xy = sample_xy(rng, (TOASTER_REGION[0], WORKER_TOASTER_Y), side)
        place_toaster(sim, xy, facing_yaw(rng, towards_minus_y=side > 0), mounted=True)
        place_bread_in_rack(sim, sample_xy(rng, (RACK_REGION[0], WORKER_RACK_Y), side), rng.uniform(-YAW, YAW))
        self.paint_episode(sim, rng)

    def instruction(self) -> str:
        return "put the bread in the toaster's slot"

    def goal_nouns(self) -> list[str]:
        return ["bread", "toaster"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        return bread_in_slot(sim) and not sim.touching_robot("bread")

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["bread", "toaster"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in insert_keyframes(sim)]
