"""A task of your own, outside the package: one arm closes its gripper on robosuite's hammer.

Use it with any command through ``--plugin examples/plugins/hammer_task.py`` (docs/extending.md):

    bimanualshift --plugin examples/plugins/hammer_task.py tasks
    bimanualshift --plugin examples/plugins/hammer_task.py collect --task grasp_hammer --episodes 20 --out data/mine

The hammer is robosuite's own object: its ``<asset>`` section (wood and metal materials, their textures) goes
into the scene next to its body, and the scene merges both.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
from robosuite.models.objects import HammerObject

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, Task, down_quat, register_task

# Bodies and geoms named hammer_*, its free joint hammer_joint0. robosuite draws the hammer's sizes, density and
# friction from its rng when the object is built: a fixed seed keeps them the same in every (worker) process, so an
# episode depends on its seed alone.
HAMMER = HammerObject(name="hammer", rng=np.random.default_rng(0))
REGION = ((-0.05, 0.10), (-0.12, 0.12))  # where the hammer lies (world x, y, metres)


@register_task("grasp_hammer")
class GraspHammer(Task):
    """Single arm: close the gripper on the hammer's handle."""

    bimanual = False

    def scene_xml(self) -> str:
        return ET.tostring(HAMMER.asset, encoding="unicode") + ET.tostring(HAMMER.get_obj(), encoding="unicode")

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        xy = np.array([rng.uniform(*REGION[0]), rng.uniform(*REGION[1])])
        # lying flat, the handle along the world x axis
        sim.set_free_pose("hammer_joint0", np.r_[xy, TABLE_TOP_Z - HAMMER.bottom_offset[2] + 0.005])
        self.episode = {"xy": xy.tolist(), "held": False}

    def instruction(self) -> str:
        return "grasp the hammer"

    def on_control_step(self, sim: SimHandle) -> None:
        if sim.touching_robot("hammer_root"):
            self.episode["held"] = True

    def evaluate_success(self, sim: SimHandle) -> bool:
        return bool(self.episode["held"])

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        handle = sim.body_pos("hammer_root")
        quat = down_quat(np.pi / 2)  # fingers close across the handle (along world y)

        def at(dz: float, gripper: float) -> Keyframe:
            return {"right": ArmAction(handle + [0.0, 0.0, dz], quat, gripper, 1.0)}

        return [at(0.12, 1.0), at(0.0, 1.0), at(0.0, 0.0)]
