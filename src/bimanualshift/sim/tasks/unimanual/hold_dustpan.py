"""Single arm: hold the dustpan steady by its handle (what ``sweep_to_dustpan``'s dustpan arm does).

The sweeping scene (dustpan, dirt, brush) lies up to 0.32 m to the arm's right, where the dustpan sits in that
arm's frame; the arm pinches the handle bar without moving the pan.
"""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.motions import hold_dustpan
from bimanualshift.sim.props.sweeping import SWEEP_DIRT, SweepTask, place_sweep_scene
from bimanualshift.sim.task import Keyframe, SimHandle, register_task

SHIFT_Y = (-0.32, 0.0)
STILL_WITHIN = 0.02  # metres the pan may move while it is taken


@register_task("hold_dustpan")
class HoldDustpan(SweepTask):
    bimanual = False
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)
    added_skill = True

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        place_sweep_scene(sim, rng, "dustpan", "brush", SWEEP_DIRT, shift_y=rng.uniform(*SHIFT_Y))
        pan_colour, brush_colour = self.pick_colours(rng, 2)
        sim.set_rgb_prefix("dustpan_", self.palette[pan_colour])
        sim.set_rgb_prefix("brush_", self.palette[brush_colour])
        start = sim.joint_qpos("dustpan_joint")[:2].tolist()
        self.episode = {"colour": pan_colour, "brush_colour": brush_colour, "pan_start": start}

    def instruction(self) -> str:
        return "hold the dustpan by its handle"

    def goal_nouns(self) -> list[str]:
        return ["dustpan"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        moved = np.linalg.norm(sim.body_pos("dustpan")[:2] - np.asarray(self.episode["pan_start"]))
        return bool(sim.pinched("dustpan") and moved < STILL_WITHIN)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["dustpan"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in hold_dustpan(sim, "dustpan", steps=4)]
