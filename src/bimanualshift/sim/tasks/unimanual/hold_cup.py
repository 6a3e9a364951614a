"""Single arm, on the UR5e twin: hold a cup steady by its handle (hold and steady), the skill of Pouring Water's
left arm. The cup stands 24-30 cm to either side of the arm, its handle towards it, as the held cup stands from
the left arm's base in that task. Success: the handle held, the cup upright and within 2 cm of its start."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z, skill_side
from bimanualshift.sim.props.cups import cup_xml
from bimanualshift.sim.task import Keyframe, SimHandle, register_task
from bimanualshift.sim.tasks.realworld.pouring_water import TARGET_REGION, YAW, PouringTask, handle_keyframes

CUP_Y = (0.24, 0.30)  # |y| from the arm's base
STILL_WITHIN = 0.02


@register_task("hold_cup")
class HoldCup(PouringTask):
    bimanual = False

    def scene_xml(self) -> str:
        return cup_xml("cup_held")

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        side = skill_side(rng)
        xy = np.array([rng.uniform(*TARGET_REGION[0]), side * rng.uniform(*CUP_Y)])
        yaw = rng.uniform(-YAW, YAW) + (0.0 if side > 0 else np.pi)  # the handle (its -y side) towards the arm
        sim.set_free_pose("cup_held_joint", np.r_[xy, TABLE_TOP_Z + 0.001], Rotation.from_euler("z", yaw).as_quat())
        colour = self.pick_colours(rng, 1)[0]
        sim.set_rgb_prefix("cup_held_", self.palette[colour])
        self.episode = {"colour": colour, "cup_start": xy.tolist()}

    def instruction(self) -> str:
        return "hold the cup steady by its handle"

    def goal_nouns(self) -> list[str]:
        return ["cup"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        up = sim.data.xmat[sim.body_id("cup_held")].reshape(3, 3)[2, 2]
        moved = np.linalg.norm(sim.body_pos("cup_held")[:2] - np.asarray(self.episode["cup_start"]))
        return bool(sim.pinched("cup_held") and moved < STILL_WITHIN and up > np.cos(np.deg2rad(10.0)))

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["cup_held"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        approach, grip = handle_keyframes(sim, "cup_held")
        return [{"right": a} for a in (approach, grip, grip)]
