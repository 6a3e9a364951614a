"""Single arm: hold the dustpan by its handle and drag it onto a target."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.motions import hold_dustpan
from bimanualshift.sim.props.markers import marker_xml
from bimanualshift.sim.props.sweeping import PAN_LENGTH, dustpan_xml
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, Task, register_task

TARGET_RADIUS = 0.04
START = ((-0.02, 0.10), (-0.08, 0.08))
SHIFT = (0.08, 0.14)  # how far the target lies from the pan's centre


@register_task("drag_dustpan")
class DragDustpan(Task):
    bimanual = False
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)

    def scene_xml(self) -> str:
        return dustpan_xml("dustpan") + marker_xml("target", TARGET_RADIUS)

    def _pan_centre(self, sim: SimHandle) -> np.ndarray:
        body = sim.body_id("dustpan")
        return sim.data.xpos[body] + sim.data.xmat[body].reshape(3, 3) @ [-PAN_LENGTH / 2, 0.0, 0.0]

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        yaw = -np.pi / 2 + rng.uniform(-0.3, 0.3)
        mouth = np.array([rng.uniform(*START[0]), rng.uniform(*START[1]), TABLE_TOP_Z])
        sim.set_free_pose("dustpan_joint", mouth, Rotation.from_euler("z", yaw).as_quat())
        centre = mouth + Rotation.from_euler("z", yaw).apply([-PAN_LENGTH / 2, 0.0, 0.0])
        angle = rng.uniform(0, 2 * np.pi)
        target = centre[:2] + rng.uniform(*SHIFT) * np.array([np.cos(angle), np.sin(angle)])
        sim.model.body_pos[sim.body_id("target")] = (*target, TABLE_TOP_Z)
        colour = self.pick_colours(rng, 1)[0]
        sim.set_rgb_prefix("dustpan_", self.palette[colour])
        self.episode = {"colour": colour}

    def instruction(self) -> str:
        return "drag the dustpan onto the target"

    def goal_nouns(self) -> list[str]:
        return ["dustpan", "target"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        return bool(np.linalg.norm(self._pan_centre(sim)[:2] - sim.body_pos("target")[:2]) < TARGET_RADIUS)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["dustpan"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        grasp = hold_dustpan(sim, "dustpan", steps=3)
        shift = np.r_[sim.body_pos("target")[:2] - self._pan_centre(sim)[:2], 0.0]
        held = grasp[-1]
        drag = ArmAction(held.position + shift + [0, 0, 0.005], held.quat, 0.0, 1.0)
        release = ArmAction(drag.position, held.quat, 1.0, 1.0)
        up = ArmAction(drag.position + [0, 0, 0.08], held.quat, 1.0, 1.0)
        return [{"right": a} for a in [*grasp, drag, release, up]]
