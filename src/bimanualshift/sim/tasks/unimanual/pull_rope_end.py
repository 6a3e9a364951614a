"""Single arm: take the end of a crumpled rope nearest the target and pull it onto the target.

Either end may be the one (the rope's head lies on its +y side): each arm of ``straighten_rope`` takes the end
on its own side. The rope lies up to 0.2 m either side of the arm, where those ends lie in each arm's frame.
"""

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
TARGET = ((-0.05, 0.12), (-0.36, 0.36))  # x, y of the target
PULL = (0.12, 0.25)  # distance from the pulled end to the target
CLEAR_OF_OTHER_END = 0.05  # the other end lies at least this much farther from the target: never ambiguous
CENTRE_Y = (-0.20, 0.20)
REACH_Y = (-0.42, 0.42)


@register_task("pull_rope_end")
class PullRopeEnd(RopeTask):
    bimanual = False

    def scene_xml(self) -> str:
        return rope_xml("rope") + marker_xml("target", TARGET_RADIUS)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        head, tail = self.crumple_rope(sim, rng, centre_y=CENTRE_Y, reach_y=REACH_Y)
        pull_head = bool(rng.random() < 0.5)
        start, other = (head, tail) if pull_head else (tail, head)
        for _ in range(1000):  # the end starts well off the target, but not across the table
            target = np.array([rng.uniform(*TARGET[0]), rng.uniform(*TARGET[1])])
            near = np.linalg.norm(target - start)
            if PULL[0] < near < PULL[1] and np.linalg.norm(target - other) > near + CLEAR_OF_OTHER_END:
                break
        sim.model.body_pos[sim.body_id("target")] = (*target, TABLE_TOP_Z)
        colour = self.pick_colours(rng, 1)[0]
        self.colour_rope(sim, colour)
        self.episode = {"colour": colour, "pull_head": pull_head}

    def instruction(self) -> str:
        return "pull the end of the rope onto the target"

    def goal_nouns(self) -> list[str]:
        return ["rope", "target"]

    def _pulled(self) -> int:
        return 0 if self.episode.get("pull_head", True) else 1

    def evaluate_success(self, sim: SimHandle) -> bool:
        end = rope_ends(sim, "rope")[self._pulled()]
        return bool(np.linalg.norm(end[:2] - sim.body_pos("target")[:2]) < TARGET_RADIUS)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["rope:head" if self._pulled() == 0 else "rope:tail"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        head = self._pulled() == 0
        return [{"right": a} for a in carry_rope_end(sim, "rope", head, sim.body_pos("target"))]
