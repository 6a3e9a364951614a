"""Straighten a rope: a crumpled rope; each arm takes one end and pulls it into its target region."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.motions import carry_rope_end, zip_arms
from bimanualshift.sim.props.markers import marker_xml
from bimanualshift.sim.props.rope import (
    RopeTask,
    rope_ends,
    rope_xml,
)
from bimanualshift.sim.task import Keyframe, SimHandle, register_task

TARGET_RADIUS = 0.06
TARGETS = {"head_target": (0.05, 0.23), "tail_target": (0.05, -0.23)}
PHRASINGS = (
    "straighten the rope",
    "pull the rope straight",
    "straighten out the rope",
    "pull both ends of the rope apart",
    "lay the rope out straight",
    "stretch the rope between the two targets",
)


@register_task("straighten_rope")
class StraightenRope(RopeTask):
    bimanual = True

    def scene_xml(self) -> str:
        return rope_xml("rope") + "".join(marker_xml(name, TARGET_RADIUS) for name in TARGETS)

    def instance_class(self, instance: str) -> str:
        return "target" if instance.endswith("_target") else instance

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        for name, xy in TARGETS.items():
            sim.model.body_pos[sim.body_id(name)] = (*xy, TABLE_TOP_Z)
        self.crumple_rope(sim, rng)
        colour = self.pick_colours(rng, 1)[0]
        self.colour_rope(sim, colour)
        self.episode = {"colour": colour, "phrasing": int(rng.integers(len(PHRASINGS)))}

    def instruction(self) -> str:
        return PHRASINGS[self.episode["phrasing"]]

    def evaluate_success(self, sim: SimHandle) -> bool:
        head, tail = rope_ends(sim, "rope")
        near = [np.linalg.norm(end[:2] - sim.body_pos(target)[:2]) < TARGET_RADIUS
                for end, target in ((head, "head_target"), (tail, "tail_target"))]
        return bool(all(near))

    def roles(self, sim: SimHandle) -> tuple[str, str]:
        """(head arm, tail arm): each arm takes the end lying on its side (the layout may be mirrored)."""
        head, tail = rope_ends(sim, "rope")
        head_arm = "left" if head[1] > tail[1] else "right"
        return head_arm, "right" if head_arm == "left" else "left"

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        head_arm, tail_arm = self.roles(sim)
        return {head_arm: ["rope:head"], tail_arm: ["rope:tail"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        head_arm, tail_arm = self.roles(sim)
        return zip_arms(**{head_arm: carry_rope_end(sim, "rope", True, sim.body_pos("head_target")),
                           tail_arm: carry_rope_end(sim, "rope", False, sim.body_pos("tail_target"))})
