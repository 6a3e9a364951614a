"""Sweep to dustpan: one arm holds the dustpan by its handle, the other takes the brush and sweeps five
pieces of dirt into the pan."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.motions import hold_dustpan, sweep_into_dustpan, zip_arms
from bimanualshift.sim.props.sweeping import (
    SWEEP_DIRT,
    SweepTask,
    place_sweep_scene,
)
from bimanualshift.sim.task import Keyframe, SimHandle, register_task

PHRASINGS = ("sweep the dirt to the dustpan", "sweep dirt to dustpan", "sweep the dirt into the dustpan",
             "brush the dirt into the dustpan")


@register_task("sweep_to_dustpan")
class SweepToDustpan(SweepTask):
    bimanual = True
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        place_sweep_scene(sim, rng, "dustpan", "brush", SWEEP_DIRT)
        pan_colour, brush_colour = self.pick_colours(rng, 2)
        sim.set_rgb_prefix("dustpan_", self.palette[pan_colour])
        sim.set_rgb_prefix("brush_", self.palette[brush_colour])
        self.episode = {"dustpan_colour": pan_colour, "brush_colour": brush_colour,
                        "phrasing": int(rng.integers(len(PHRASINGS)))}

    def instruction(self) -> str:
        return PHRASINGS[self.episode["phrasing"]]

    def roles(self, sim: SimHandle) -> tuple[str, str]:
        """(dustpan arm, brush arm): the arm on the dustpan's side holds it; the other sweeps towards it (a
        mirrored layout swaps them)."""
        pan_arm = "left" if sim.body_pos("dustpan")[1] > sim.body_pos("brush")[1] else "right"
        return pan_arm, "right" if pan_arm == "left" else "left"

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        pan_arm, brush_arm = self.roles(sim)
        return {pan_arm: ["dustpan"], brush_arm: ["brush"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        pan_arm, brush_arm = self.roles(sim)
        sweep = sweep_into_dustpan(sim, "brush", "dustpan", SWEEP_DIRT)
        return zip_arms(**{pan_arm: hold_dustpan(sim, "dustpan", len(sweep)), brush_arm: sweep})
