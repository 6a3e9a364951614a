"""Single arm: sweep five pieces of dirt into a dustpan with a brush (the dustpan stands free)."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.motions import sweep_into_dustpan
from bimanualshift.sim.props.sweeping import (
    SWEEP_DIRT,
    SweepTask,
    place_sweep_scene,
)
from bimanualshift.sim.task import Keyframe, SimHandle, register_task

# The scene up to 0.32 m to the left: sweep_to_dustpan's brush arm has it 0.30 m to its left.
SHIFT_Y = (0.0, 0.32)


@register_task("sweep_dirt")
class SweepDirt(SweepTask):
    bimanual = False
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        place_sweep_scene(sim, rng, "dustpan", "brush", SWEEP_DIRT, shift_y=rng.uniform(*SHIFT_Y))
        colour = self.pick_colours(rng, 1)[0]
        sim.set_rgb_prefix("brush_", self.palette[colour])
        self.episode = {"colour": colour}

    def instruction(self) -> str:
        return "sweep the dirt into the dustpan with the brush"

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["brush"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in sweep_into_dustpan(sim, "brush", "dustpan", SWEEP_DIRT)]
