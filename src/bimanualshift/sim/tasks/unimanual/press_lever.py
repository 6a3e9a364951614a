"""Single arm, on the UR5e twin: press the toaster's lever down until it latches (press), the skill of Toaster
Activation's right arm. The toaster is fixed to the table 32-37 cm to either side of the arm, its lever towards
it, as it stands from the right arm's base in the toaster tasks."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import skill_side
from bimanualshift.sim.props.toaster import place_toaster, toaster_xml
from bimanualshift.sim.task import Keyframe, SimHandle, register_task
from bimanualshift.sim.tasks.realworld.toaster_scene import (
    TOASTER_REGION,
    WORKER_TOASTER_Y,
    ToasterTask,
    facing_yaw,
    lever_keyframes,
    sample_xy,
)


@register_task("press_lever")
class PressLever(ToasterTask):
    bimanual = False
    toaster_mounted = True

    def scene_xml(self) -> str:
        return toaster_xml("toaster", mounted=True)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        side = skill_side(rng)
        xy = sample_xy(rng, (TOASTER_REGION[0], WORKER_TOASTER_Y), side)
        place_toaster(sim, xy, facing_yaw(rng, towards_minus_y=side > 0), mounted=True)
        self.paint_episode(sim, rng)

    def instruction(self) -> str:
        return "press the toaster's lever down"

    def goal_nouns(self) -> list[str]:
        return ["toaster"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        return bool(self.episode.get("latched"))

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["toaster"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in lever_keyframes(sim)]
