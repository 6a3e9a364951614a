"""Single arm: open the oven door by pulling its handle down until the door falls open."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.motions import hover, open_oven_door
from bimanualshift.sim.props.oven import PLINTH, door_angle, oven_frame, oven_xml, place_oven, place_tray, tray_xml
from bimanualshift.sim.task import Keyframe, SimHandle, Task, register_task

OPEN_ANGLE = np.deg2rad(70)
MOUTH_X = (0.04, 0.10)
# Up to 0.38 m either side: take_tray_out_of_oven's door arm meets the oven 0.24-0.36 m to its side.
MOUTH_Y = (-0.38, 0.38)
HOOK_SHIFT = 0.04  # the hook moves along the handle towards the arm as the oven moves to the side


def towards_arm(mouth_y: float) -> float:
    """-1 .. 1: which way (oven-local y) the arm lies, reaching +-1 from 0.24 m to the side (as a bimanual door
    arm hooks the handle from its own side)."""
    return float(np.clip(-mouth_y / 0.24, -1.0, 1.0))


@register_task("open_oven_door")
class OpenOvenDoor(Task):
    bimanual = False
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)

    def scene_xml(self) -> str:
        return oven_xml("oven") + tray_xml("tray", round_tray=self.perturbations.unseen_shapes)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        frame = place_oven(sim, rng, "oven", MOUTH_X, MOUTH_Y, np.pi / 8)
        place_tray(sim, frame, "tray", rng.uniform(-0.04, 0.04))
        colour = self.pick_colours(rng, 1)[0]
        sim.set_rgb("oven_door_panel", self.palette[colour])
        self.episode = {"colour": colour}

    def instruction(self) -> str:
        return "open the oven door"

    def evaluate_success(self, sim: SimHandle) -> bool:
        return door_angle(sim, "oven") > OPEN_ANGLE

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["oven"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        frame = oven_frame(sim, "oven")
        side = towards_arm(sim.body_pos("oven")[1])
        away = hover(frame, np.array([-0.22, 0.22 * side, PLINTH + 0.40]), 0.0)
        return [{"right": a} for a in [*open_oven_door(frame, hook_y=HOOK_SHIFT * side), away]]
