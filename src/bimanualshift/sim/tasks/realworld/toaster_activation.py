"""Toaster activation (the paper's real-world Collaboration tier, 6 keyframes): the left arm holds the toaster by
its handle while the right arm presses the lever down until it latches. The toaster is light and the lever's
spring stiff: pressed alone, it tips over its lever end before the lever latches (``sim/props/toaster.py``).
Success: the lever latched, the toaster never rocked by more than 6 degrees and stands within 3 cm of where it
stood."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.props.toaster import place_toaster, toaster_xml
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, register_task
from bimanualshift.sim.tasks.realworld.toaster_scene import (
    TOASTER_REGION,
    YAW,
    ToasterTask,
    handle_keyframes,
    lever_keyframes,
    roles,
    sample_xy,
)


@register_task("toaster_activation")
class ToasterActivation(ToasterTask):
    bimanual = True
    tier = "Collaboration"
    paper_keyframes = 6

    def scene_xml(self) -> str:
        return toaster_xml("toaster")

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        place_toaster(sim, sample_xy(rng, TOASTER_REGION), rng.uniform(-YAW, YAW))
        self.paint_episode(sim, rng)

    def instruction(self) -> str:
        return "hold the toaster and press its lever down"

    def goal_nouns(self) -> list[str]:
        return ["toaster"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        return bool(self.episode.get("latched")) and self.toaster_still(sim)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {arm: ["toaster"] for arm in roles(sim)}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        hold = handle_keyframes(sim, holds=3)
        grip = hold[-1]
        hold.append(ArmAction(grip.position, grip.quat, 1.0, 1.0))  # let go once the lever is latched
        press = lever_keyframes(sim)
        # the right arm waits above the lever while the left grips the handle, and stays up at the end
        press = [press[0], *press, press[-1]]
        holder, worker = roles(sim)
        return [{holder: h, worker: p} for h, p in zip(hold, press, strict=True)]
