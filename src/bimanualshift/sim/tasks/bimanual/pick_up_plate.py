"""Pick up a plate: a wide plate lying flat; each arm pinches the rim on its side and both lift it level."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.plate import RIM_HEIGHT, PlateLiftTask, plate_xml
from bimanualshift.sim.task import DOWN_QUAT, ArmAction, Keyframe, SimHandle, register_task

RADIUS = 0.12
REGION = ((-0.06, 0.12), (-0.08, 0.08))
LIFTED_BY = 0.08
GRASP_HEIGHT = RIM_HEIGHT - 0.008  # gripper site height above the table: pads level with the rim


@register_task("pick_up_plate")
class PickUpPlate(PlateLiftTask):
    region, yaw_range, lifted_by = REGION, (-np.pi / 8, np.pi / 8), LIFTED_BY
    bimanual = True
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)

    def scene_xml(self) -> str:
        return plate_xml("plate", RADIUS, square=self.perturbations.unseen_shapes, mass=0.25)

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        centre = sim.body_pos("plate")
        centre[2] = TABLE_TOP_Z
        side = {"left": 1.0, "right": -1.0}  # each arm takes the rim on its own side

        def at(dz: float, gripper: float) -> Keyframe:
            return {arm: ArmAction(centre + [0.0, s * RADIUS, GRASP_HEIGHT + dz], DOWN_QUAT, gripper, 1.0)
                    for arm, s in side.items()}

        return [at(0.10, 1.0), at(0.0, 1.0), at(0.0, 0.0), at(LIFTED_BY + 0.06, 0.0)]
