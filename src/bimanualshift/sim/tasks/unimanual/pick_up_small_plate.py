"""Single arm: pick up a small plate by pinching its rim.

In front of the arm the plate is taken by the rim facing the robot; off to one side (where a bimanual plate lies
in each arm's frame) by the rim facing the arm's centre line, fingers across it, as each arm of
``pick_up_plate`` takes its side.
"""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.plate import RIM_HEIGHT, PlateLiftTask, plate_xml
from bimanualshift.sim.task import DOWN_QUAT, ArmAction, Keyframe, SimHandle, down_quat, register_task

RADIUS = 0.07
REGION = ((0.04, 0.16), (-0.15, 0.15))  # the near rim stays clear of the base, where the wrist turn fails
# Off to either side (|y| in SIDE_Y): where pick_up_plate's plate sits in each arm's frame (docs/tasks.md).
SIDE_X = (-0.08, 0.14)
SIDE_Y = (0.20, 0.42)
SIDE_FROM = 0.175  # |y| from which the side rim is taken (between the two regions: never ambiguous)
LIFTED_BY = 0.05
GRASP_HEIGHT = RIM_HEIGHT - 0.008  # gripper site above the table: pads level with the rim


@register_task("pick_up_small_plate")
class PickUpSmallPlate(PlateLiftTask):
    region, yaw_range, lifted_by = REGION, (0.0, np.pi), LIFTED_BY
    bimanual = False
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)

    def scene_xml(self) -> str:
        return plate_xml("plate", RADIUS, square=self.perturbations.unseen_shapes, mass=0.08)

    def sample_xy(self, rng: np.random.Generator) -> np.ndarray:
        where = rng.integers(3)  # in front, to the left, to the right: equally often
        if where == 0:
            return super().sample_xy(rng)
        side = 1.0 if where == 1 else -1.0
        return np.array([rng.uniform(*SIDE_X), side * rng.uniform(*SIDE_Y)])

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        centre = sim.body_pos("plate")
        if abs(centre[1]) >= SIDE_FROM:  # the rim facing the arm's centre line, fingers along y
            rim = np.r_[centre[:2] - [0.0, np.sign(centre[1]) * RADIUS], TABLE_TOP_Z + GRASP_HEIGHT]
            quat = DOWN_QUAT
        else:  # the rim point nearest the robot, fingers along x: one over the plate, one outside the rim
            rim = np.r_[centre[:2] - [RADIUS, 0.0], TABLE_TOP_Z + GRASP_HEIGHT]
            quat = down_quat(np.pi / 2)
        return [{"right": ArmAction(rim + [0, 0, dz], quat, g, 1.0)}
                for dz, g in ((0.10, 1.0), (0.0, 1.0), (0.0, 0.0), (LIFTED_BY + 0.06, 0.0))]
