"""Single arm: the oven stands open; slide the tray out by its tab onto the door and let go."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.motions import pull_tray_out
from bimanualshift.sim.props.oven import TRAY_HALF, oven_frame, oven_xml, place_oven, place_tray, tray_xml
from bimanualshift.sim.task import Keyframe, SimHandle, Task, register_task

MOUTH_X = (0.04, 0.10)
# Up to 0.40 m either side: take_tray_out_of_oven's tray arm meets the tray 0.18-0.42 m to its side.
MOUTH_Y = (-0.40, 0.40)


@register_task("take_tray_out_of_open_oven")
class TakeTrayOutOfOpenOven(Task):
    bimanual = False

    def scene_xml(self) -> str:
        return oven_xml("oven") + tray_xml("tray", round_tray=self.perturbations.unseen_shapes)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        frame = place_oven(sim, rng, "oven", MOUTH_X, MOUTH_Y, np.pi / 8, door_angle=np.pi / 2)
        place_tray(sim, frame, "tray", rng.uniform(-0.04, 0.04))
        colour = self.pick_colours(rng, 1)[0]
        sim.set_rgb_prefix("tray_", self.palette[colour])
        self.episode = {"colour": colour}

    def instruction(self) -> str:
        return "take the tray out of the open oven"

    def evaluate_success(self, sim: SimHandle) -> bool:
        tray = oven_frame(sim, "oven").to_local(sim.body_pos("tray"))
        return bool(tray[0] < -TRAY_HALF[0] and not sim.touching_robot("tray"))

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["tray"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in pull_tray_out(oven_frame(sim, "oven"), sim.body_pos("tray"))]
