"""Single arm, on the UR5e twin: take the toast out of the toaster's slot and put it on the plate (pick and
place), the last two stages of `serve_toast` for its right arm. The toaster is fixed to the table 32-37 cm to
either side of the arm with the toast standing in its slot; the plate lies 0-5 cm out on the same side, as both
stand from the right arm's base in that task."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z, skill_side
from bimanualshift.sim.props.plate import plate_xml
from bimanualshift.sim.props.toaster import (
    TOAST_COLOUR,
    bread_xml,
    place_bread_in_slot,
    place_toaster,
    toaster_xml,
    yaw_of,
)
from bimanualshift.sim.task import Keyframe, SimHandle, register_task
from bimanualshift.sim.tasks.realworld.toaster_scene import (
    PLATE_RADIUS,
    PLATE_REGION,
    TOASTER_REGION,
    WORKER_PLATE_Y,
    WORKER_TOASTER_Y,
    ToasterTask,
    facing_yaw,
    place_keyframes,
    sample_xy,
    toast_on_plate,
)


@register_task("place_toast")
class PlaceToast(ToasterTask):
    bimanual = False
    toaster_mounted = True

    def scene_xml(self) -> str:
        return toaster_xml("toaster", mounted=True) + bread_xml("bread") + plate_xml("plate", PLATE_RADIUS)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        side = skill_side(rng)
        xy, yaw = sample_xy(rng, (TOASTER_REGION[0], WORKER_TOASTER_Y), side), facing_yaw(rng, side > 0)
        place_toaster(sim, xy, yaw, mounted=True)
        place_bread_in_slot(sim, xy, yaw)
        sim.set_free_pose("plate_joint", np.r_[sample_xy(rng, (PLATE_REGION[0], WORKER_PLATE_Y), side), TABLE_TOP_Z])
        toaster_colour, plate_colour = self.pick_colours(rng, 2)
        self.paint_toaster(sim, toaster_colour)
        sim.set_rgb("bread_geom", TOAST_COLOUR)
        sim.set_rgb_prefix("plate_", self.palette[plate_colour])
        self.episode = {"colour": toaster_colour, "plate_colour": plate_colour}
        self.record_start(sim)
        self.episode["latched"] = True  # it has toasted

    def instruction(self) -> str:
        return "put the toasted bread on the plate"

    def goal_nouns(self) -> list[str]:
        return ["bread", "plate"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        return toast_on_plate(sim)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["bread", "plate"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in place_keyframes(sim, (sim.body_pos("bread"), yaw_of(sim, "bread")))]
