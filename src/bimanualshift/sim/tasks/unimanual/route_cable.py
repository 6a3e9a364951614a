"""Single arm, on the UR5e twin: lay a cable through a clip (route a cable), the skill of each arm of Cable Routing.
The cable's far end is clamped to the table; the arm takes the plug at the near end, lifts the cable clear of the
clip, carries it over the point the taut cable reaches past the clip, and lays it down the clip's gap, holding it.
The near plug lies 4-9 cm to either side of the arm and the cable runs away from it, as each arm's plug lies in
Cable Routing; the clip stands on the line from the clamp to where the plug is laid. Success: the cable down the
clip's gap and the plug past it."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z, skill_side
from bimanualshift.sim.props.cable import PLUG_CENTRES, PLUG_HALF, anchor_plug, cable_xml, clip_xml, through_clip
from bimanualshift.sim.task import Keyframe, SimHandle, register_task
from bimanualshift.sim.tasks.realworld.cable_routing import (
    CABLE_BEFORE,
    CLIP_X,
    SPAN,
    CableTask,
    outside,
    route_keyframes,
)

PLUG_Y = (0.04, 0.09)  # |y| of the near plug from the arm's base
CLIP_FROM_END = (0.13, 0.16)  # the clip stands this far from where the plug is laid, towards the clamp


@register_task("route_cable")
class RouteCable(CableTask):
    bimanual = False

    def scene_xml(self) -> str:
        return cable_xml(anchored="head") + clip_xml("clip")

    def instruction(self) -> str:
        return "route the cable through the clip"

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        side = skill_side(rng)
        # the free plug (the tail) near the arm and the cable running away from it to the clamped head: to the
        # arm's left, as the right arm's plug lies in Cable Routing, or to its right, as the left arm's
        x = rng.uniform(*CLIP_X) - rng.uniform(*CABLE_BEFORE)
        near = side * rng.uniform(*PLUG_Y)
        self.lay(sim, rng, np.array([x, near + side * (PLUG_CENTRES - PLUG_HALF[0])]), -side * np.pi / 2)
        anchor_plug(sim, "head")
        clamp = sim.body_pos("cable_plug_head")[:2]
        over_x = rng.uniform(*CLIP_X)
        over = np.array([over_x, clamp[1] - side * np.sqrt(max(SPAN**2 - (over_x - clamp[0]) ** 2, 0.0))])
        line = over - clamp
        clip = over - line / np.linalg.norm(line) * rng.uniform(*CLIP_FROM_END)
        body = sim.body_id("clip")
        sim.model.body_pos[body] = (*clip, TABLE_TOP_Z)
        # the clip's gap along the line (its posts either side of it), turned the way Cable Routing's clips are
        # (a clip is the same turned half a turn)
        yaw = (np.arctan2(line[1], line[0]) - np.pi / 2 + np.pi / 2) % np.pi - np.pi / 2
        sim.model.body_quat[body] = np.roll(Rotation.from_euler("z", yaw).as_quat(), 1)
        self.episode.update(over=over.tolist(), clamp=clamp.tolist())

    def evaluate_success(self, sim: SimHandle) -> bool:
        return through_clip(sim, "clip") and outside(sim, "tail", "clip", np.asarray(self.episode["clamp"]))

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["cable_plug_tail", "clip"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in route_keyframes(sim, "tail", np.asarray(self.episode["over"]))]
