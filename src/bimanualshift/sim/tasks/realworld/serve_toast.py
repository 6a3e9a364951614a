"""Serve toast (the paper's long-horizon task, Fig. 11b): insert the bread, press the lever, grasp the toast,
place it on the plate. The left arm holds the toaster by its handle throughout; the right arm does the four
stages in turn (15 keyframes). The first two stages are Toasting Completion and Toaster Activation; the last two
are new: the toast is taken out of the slot by its exposed top and let go of over the plate.

Stages: insert (the slice let go of in the slot), press (the lever latched, the bread toasted), grasp (the toast
held, lifted clear of the toaster), place (the toast on the plate, let go of, the toaster steady throughout)."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.plate import plate_xml
from bimanualshift.sim.props.toaster import (
    BREAD,
    HEIGHT,
    bread_in_slot,
    bread_xml,
    place_bread_in_rack,
    place_toaster,
    rack_xml,
    toaster_xml,
)
from bimanualshift.sim.task import Keyframe, SimHandle, register_task
from bimanualshift.sim.tasks.realworld.toaster_scene import (
    PLATE_RADIUS,
    PLATE_REGION,
    RACK_REGION,
    TOASTER_REGION,
    YAW,
    ToasterTask,
    handle_keyframes,
    insert_keyframes,
    lever_keyframes,
    place_keyframes,
    roles,
    sample_xy,
    slice_in_slot,
    toast_on_plate,
)


@register_task("serve_toast")
class ServeToast(ToasterTask):
    bimanual = True
    stage_names = ("insert", "press", "grasp", "place")

    def scene_xml(self) -> str:
        return toaster_xml("toaster") + rack_xml("rack") + bread_xml("bread") + plate_xml("plate", PLATE_RADIUS)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        place_toaster(sim, sample_xy(rng, TOASTER_REGION), rng.uniform(-YAW, YAW))
        place_bread_in_rack(sim, sample_xy(rng, RACK_REGION), rng.uniform(-YAW, YAW))
        sim.set_free_pose("plate_joint", np.r_[sample_xy(rng, PLATE_REGION), TABLE_TOP_Z])
        toaster_colour, plate_colour = self.pick_colours(rng, 2)
        self.paint_toaster(sim, toaster_colour)
        sim.set_rgb_prefix("plate_", self.palette[plate_colour])
        self.episode = {"colour": toaster_colour, "plate_colour": plate_colour}
        self.record_start(sim)

    def instruction(self) -> str:
        return "toast the bread and serve it on the plate"

    def goal_nouns(self) -> list[str]:
        return ["toaster", "bread", "plate"]

    def evaluate_stages(self, sim: SimHandle) -> list[bool]:
        inserted = bread_in_slot(sim) and not sim.touching_robot("bread")
        lifted = sim.body_pos("bread")[2] - BREAD[2] > TABLE_TOP_Z + HEIGHT + 0.01 and sim.pinched("bread")
        return [bool(inserted), bool(self.episode.get("latched")), bool(lifted), self.placed(sim)]

    def placed(self, sim: SimHandle) -> bool:
        return toast_on_plate(sim) and self.toaster_still(sim)

    def evaluate_success(self, sim: SimHandle) -> bool:
        # the first three stages reached in order earlier (latched by update_stages), the toast placed now
        return int(self.episode.get("stages_done", 0)) >= 3 and self.placed(sim)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        holder, worker = roles(sim)
        return {holder: ["toaster"], worker: ["bread", "toaster", "plate"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        right = insert_keyframes(sim) + lever_keyframes(sim)
        # the plan is made before the slice moves: the toast is taken from where the slot will hold it
        right += place_keyframes(sim, slice_in_slot(sim))
        hold = handle_keyframes(sim, holds=len(right) - 2)
        holder, worker = roles(sim)
        return [{holder: h, worker: r} for h, r in zip(hold, right, strict=True)]
