"""Single arm: pick up a small plate by pinching its rim on the side facing the robot."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.plate import RIM_HEIGHT, PlateLiftTask, plate_xml
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, down_quat, register_task

RADIUS = 0.07
REGION = ((0.04, 0.16), (-0.15, 0.15))  # the near rim stays clear of the base, where the wrist turn fails
LIFTED_BY = 0.05
GRASP_HEIGHT = RIM_HEIGHT - 0.008  # gripper site above the table: pads level with the rim


@register_task("pick_up_small_plate")
class PickUpSmallPlate(PlateLiftTask):
    region, yaw_range, lifted_by = REGION, (0.0, np.pi), LIFTED_BY
    bimanual = False

    def scene_xml(self) -> str:
        return plate_xml("plate", RADIUS, square=self.perturbations.unseen_shapes, mass=0.08)

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        centre = sim.body_pos("plate")
        rim = np.r_[centre[:2] - [RADIUS, 0.0], TABLE_TOP_Z + GRASP_HEIGHT]  # the rim point nearest the robot
        quat = down_quat(np.pi / 2)  # fingers open along x: one over the plate, one outside the rim
        return [{"right": ArmAction(rim + [0, 0, dz], quat, g, 1.0)}
                for dz, g in ((0.10, 1.0), (0.0, 1.0), (0.0, 0.0), (LIFTED_BY + 0.06, 0.0))]
