"""Toasting completion (the paper's real-world Coordination tier, 6 keyframes): the left arm steadies the toaster
by its handle while the right arm takes the slice of bread from its rack and lowers it into the slot. Success:
the slice let go of, standing in the slot at least 3 cm deep, and the toaster never rocked by more than 6 degrees
and within 3 cm of where it stood."""

from __future__ import annotations

import numpy as np

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
    YAW,
    ToasterTask,
    handle_keyframes,
    insert_keyframes,
    roles,
    sample_xy,
)


@register_task("toasting_completion")
class ToastingCompletion(ToasterTask):
    bimanual = True
    tier = "Coordination"
    paper_keyframes = 6

    def scene_xml(self) -> str:
        return toaster_xml("toaster") + rack_xml("rack") + bread_xml("bread")

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        place_toaster(sim, sample_xy(rng, TOASTER_REGION), rng.uniform(-YAW, YAW))
        place_bread_in_rack(sim, sample_xy(rng, RACK_REGION), rng.uniform(-YAW, YAW))
        self.paint_episode(sim, rng)

    def instruction(self) -> str:
        return "hold the toaster and put the bread in its slot"

    def goal_nouns(self) -> list[str]:
        return ["toaster", "bread"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        return bread_in_slot(sim) and not sim.touching_robot("bread") and self.toaster_still(sim)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        holder, worker = roles(sim)
        return {holder: ["toaster"], worker: ["bread", "toaster"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        hold = handle_keyframes(sim, holds=4)
        holder, worker = roles(sim)
        return [{holder: h, worker: i} for h, i in zip(hold, insert_keyframes(sim), strict=True)]
