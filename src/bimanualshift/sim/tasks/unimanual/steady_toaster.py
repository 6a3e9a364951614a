"""Single arm, on the UR5e twin: hold the toaster steady by its handle (hold and steady), the skill of the toaster
tasks' left arm. The toaster stands 23-28 cm to either side of the arm, its handle towards it, as it stands from
the left arm's base in those tasks. Success: the handle held, the toaster upright and within 3 cm of its start."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import skill_side
from bimanualshift.sim.props.toaster import place_toaster, toaster_xml
from bimanualshift.sim.task import Keyframe, SimHandle, register_task
from bimanualshift.sim.tasks.realworld.toaster_scene import (
    HOLDER_TOASTER_Y,
    TOASTER_REGION,
    ToasterTask,
    facing_yaw,
    handle_keyframes,
    sample_xy,
)


@register_task("steady_toaster")
class SteadyToaster(ToasterTask):
    bimanual = False

    def scene_xml(self) -> str:
        return toaster_xml("toaster")

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        side = skill_side(rng)
        xy = sample_xy(rng, (TOASTER_REGION[0], HOLDER_TOASTER_Y), side)
        place_toaster(sim, xy, facing_yaw(rng, towards_minus_y=side < 0))  # the handle (+y end) towards the arm
        self.paint_episode(sim, rng)

    def instruction(self) -> str:
        return "hold the toaster steady by its handle"

    def goal_nouns(self) -> list[str]:
        return ["toaster"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        return sim.pinched("toaster") and self.toaster_still(sim)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["toaster"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in handle_keyframes(sim, holds=1)]
