"""Take the tray out of the oven: one arm pulls the oven door open by its handle, the other slides the tray
out by its tab onto the opened door and lets go."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.motions import hover, open_oven_door, pull_tray_out, zip_arms
from bimanualshift.sim.props.oven import PLINTH, TRAY_HALF, oven_frame, oven_xml, place_oven, place_tray, tray_xml
from bimanualshift.sim.task import Keyframe, SimHandle, Task, register_task

MOUTH_X = (0.04, 0.10)  # where the oven's mouth stands (world x), its centre's y and its turn
MOUTH_Y = (-0.06, 0.06)
YAW = np.pi / 8
DOOR_OPEN_AT = np.pi / 3  # hinge angle (0 shut, pi/2 level) from which the tray can slide out
# How much further than the Panda the twin's hand slides the tray out: the Robotiq 140's fingers, opening, push the
# tab back about 5 cm (the tray ended 5 cm out where it must be 9 cm out, in 7 of 10 seeds); 6 cm more leaves it out
FURTHER_PULL = {"ur5e": 0.06}
PHRASINGS = (
    "take the tray out of the oven",
    "take tray out of oven",
    "remove the tray from the oven",
    "pull the tray out of the oven",
    "get the tray out of the oven",
    "open the oven and take out the tray",
    "slide the tray out of the oven",
)


@register_task("take_tray_out_of_oven")
class TakeTrayOutOfOven(Task):
    bimanual = True
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)
    stage_names = ("door open", "tray out")

    def scene_xml(self) -> str:
        return oven_xml("oven") + tray_xml("tray", round_tray=self.perturbations.unseen_shapes)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        frame = place_oven(sim, rng, "oven", MOUTH_X, MOUTH_Y, YAW)
        # Off-centre towards the side the oven's mouth is turned to, so the arm it faces takes the tray (see
        # roles): an arm reaching round a mouth turned away from it misses the tab.
        towards = -1.0 if frame.yaw >= 0 else 1.0
        place_tray(sim, frame, "tray", towards * rng.uniform(0.01, 0.04))
        colour = self.pick_colours(rng, 1)[0]
        sim.set_rgb_prefix("tray_", self.palette[colour])
        self.episode = {"colour": colour, "phrasing": int(rng.integers(len(PHRASINGS)))}

    def instruction(self) -> str:
        return PHRASINGS[self.episode["phrasing"]]

    def goal_nouns(self) -> list[str]:
        return ["tray", "oven"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        tray = oven_frame(sim, "oven").to_local(sim.body_pos("tray"))
        return bool(tray[0] < -TRAY_HALF[0] and not sim.touching_robot("tray"))  # all of it out, let go

    def evaluate_stages(self, sim: SimHandle) -> list[bool]:
        door_open = float(sim.joint_qpos("oven_door_hinge")[0]) >= DOOR_OPEN_AT
        return [door_open, self.evaluate_success(sim)]

    def roles(self, sim: SimHandle) -> tuple[str, str]:
        """(door arm, tray arm). The tray sits off-centre: the arm on its side takes it, the other opens the
        door from its own side (so a mirrored layout swaps the roles)."""
        door_arm = "left" if oven_frame(sim, "oven").to_local(sim.body_pos("tray"))[1] <= 0 else "right"
        return door_arm, "right" if door_arm == "left" else "left"

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        door_arm, tray_arm = self.roles(sim)
        return {door_arm: ["oven"], tray_arm: ["tray"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        frame = oven_frame(sim, "oven")
        door_arm, tray_arm = self.roles(sim)
        side = 1.0 if door_arm == "left" else -1.0
        door = open_oven_door(frame, hook_y=side * 0.04)
        tray = pull_tray_out(frame, sim.body_pos("tray"), FURTHER_PULL.get(self.robot, 0.0))
        wait = hover(frame, np.array([-0.18, -side * 0.20, PLINTH + 0.40]), 1.0)
        parked = hover(frame, np.array([-0.22, side * 0.22, PLINTH + 0.40]), 0.0)
        return zip_arms(**{door_arm: door + [parked] * len(tray), tray_arm: [wait] * len(door) + tray})
