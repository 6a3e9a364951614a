"""Single arm, on the UR5e twin: put the named vegetable into the bin (pick and place), a distractor beside it.

The skill each arm of `vegetable_sorting` needs. In that task an arm's vegetables lie 11-26 cm towards the robot's
centre line from its base and its bin 4-10 cm outwards; here the one arm (at y = 0) meets either side's layout:
the vegetables on one side of it, the bin on the other."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z, skill_side
from bimanualshift.sim.props.placement import sample_separated
from bimanualshift.sim.props.vegetables import VEGETABLES, bin_xml, vegetable_xml
from bimanualshift.sim.task import Keyframe, SimHandle, Task, register_task
from bimanualshift.sim.tasks.realworld.vegetable_sorting import PARKED, in_bin, place_keyframes

CATEGORIES = tuple(VEGETABLES)
VEGETABLE_X, VEGETABLE_Y = (-0.12, 0.08), (0.11, 0.26)  # |y| from the arm, on the side facing the bin's other
BIN_X, BIN_Y = (0.0, 0.10), (0.04, 0.10)


@register_task("place_vegetable")
class PlaceVegetable(Task):
    bimanual = False
    robot = "ur5e"

    def scene_xml(self) -> str:
        return "".join(vegetable_xml(c) for c in CATEGORIES) + bin_xml("bin_0")

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        side = skill_side(rng)  # the bin's side of the arm; the vegetables on the other
        chosen = [str(c) for c in rng.permutation(CATEGORIES)[:2]]  # the named one and a distractor
        colours = self.pick_colours(rng, 2)
        sim.model.body_pos[sim.body_id("bin_0")] = [rng.uniform(*BIN_X), side * rng.uniform(*BIN_Y), TABLE_TOP_Z]
        y = (-VEGETABLE_Y[1], -VEGETABLE_Y[0]) if side > 0 else VEGETABLE_Y
        spots = sample_separated(rng, [(VEGETABLE_X, y)] * 2, min_distance=0.15)
        for category in CATEGORIES:
            if category not in chosen:
                sim.set_free_pose(f"{category}_joint", PARKED + [0.0, 0.2 * CATEGORIES.index(category), 0.0])
        for i, category in enumerate(chosen):
            yaw = rng.uniform(np.pi / 4, 3 * np.pi / 4)
            half = VEGETABLES[category][2]
            sim.set_free_pose(f"{category}_joint", np.r_[spots[i], TABLE_TOP_Z + half + 0.001],
                              Rotation.from_euler("z", yaw).as_quat())
            sim.set_rgb(f"{category}_geom", self.palette[colours[i]])
        self.episode = {"target": chosen[0], "distractor": chosen[1], "colours": dict(zip(chosen, colours))}

    def instruction(self) -> str:
        return f"put the {self.episode['target']} in the bin"

    def goal_nouns(self) -> list[str]:
        return [self.episode["target"], "bin"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        return in_bin(sim, self.episode["target"], "bin_0")

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": [self.episode["target"], "bin_0"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in place_keyframes(sim, self.episode["target"], "bin_0")]
