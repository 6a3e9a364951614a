"""Single arm: sweep five pieces of dirt into a dustpan with a brush (the dustpan stands free)."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.motions import sweep_into_dustpan
from bimanualshift.sim.props.sweeping import brush_xml, dirt_in_pan, dirt_xml, dustpan_xml, place_sweep_scene
from bimanualshift.sim.task import Keyframe, SimHandle, Task, register_task

DIRT = tuple(f"dirt_{i}" for i in range(5))


@register_task("sweep_dirt")
class SweepDirt(Task):
    bimanual = False

    def scene_xml(self) -> str:
        return (dustpan_xml("dustpan") + brush_xml("brush", round_stick=self.perturbations.unseen_shapes)
                + "".join(dirt_xml(d) for d in DIRT))

    def instance_class(self, instance: str) -> str:
        return "dirt" if instance.startswith("dirt") else instance

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        place_sweep_scene(sim, rng, "dustpan", "brush", DIRT)
        colour = self.pick_colours(rng, 1)[0]
        sim.set_rgb_prefix("brush_", self.palette[colour])
        self.episode = {"colour": colour}

    def instruction(self) -> str:
        return "sweep the dirt into the dustpan with the brush"

    def goal_nouns(self) -> list[str]:
        return ["dirt", "dustpan", "brush"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        return dirt_in_pan(sim, "dustpan", DIRT)

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in sweep_into_dustpan(sim, "brush", "dustpan", DIRT)]
