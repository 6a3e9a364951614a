"""Single arm: take one end of a crumpled rope and pull it onto a target."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.motions import carry_rope_end
from bimanualshift.sim.props.markers import marker_xml
from bimanualshift.sim.props.rope import (
    RopeTask,
    rope_ends,
    rope_xml,
)
from bimanualshift.sim.task import Keyframe, SimHandle, register_task

TARGET_RADIUS = 0.06
TARGET = ((-0.05, 0.12), (-0.28, 0.28))  # x, y of the target
PULL = (0.12, 0.25)  # distance from the rope's head to the target


@register_task("pull_rope_end")
class PullRopeEnd(RopeTask):
    bimanual = False

    def scene_xml(self) -> str:
        return rope_xml("rope") + marker_xml("target", TARGET_RADIUS)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        start = self.crumple_rope(sim, rng)
        for _ in range(1000):  # the head starts well off the target, but not across the table
            target = np.array([rng.uniform(*TARGET[0]), rng.uniform(*TARGET[1])])
            if PULL[0] < np.linalg.norm(target - start) < PULL[1]:
                break
        sim.model.body_pos[sim.body_id("target")] = (*target, TABLE_TOP_Z)
        colour = self.pick_colours(rng, 1)[0]
        self.colour_rope(sim, colour)
        self.episode = {"colour": colour}

    def instruction(self) -> str:
        return "pull the end of the rope onto the target"

    def goal_nouns(self) -> list[str]:
        return ["rope", "target"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        head = rope_ends(sim, "rope")[0]
        return bool(np.linalg.norm(head[:2] - sim.body_pos("target")[:2]) < TARGET_RADIUS)

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in carry_rope_end(sim, "rope", True, sim.body_pos("target"))]
