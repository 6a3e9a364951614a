"""Lift a ball: a large ball too wide for one gripper; both arms squeeze it from the sides and lift it."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.ball import BALL_RADIUS, ball_xml
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, Task, down_quat, register_task

REGION = ((-0.08, 0.12), (-0.10, 0.10))
LIFTED_BY = 0.10  # metres the ball's centre must rise
SQUEEZE = 0.025  # how far inside the ball each hand is commanded: the OSC spring then presses it


@register_task("lift_ball")
class LiftBall(Task):
    bimanual = True
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)

    def scene_xml(self) -> str:
        return ball_xml("ball", cube=self.perturbations.unseen_shapes)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        xy = np.array([rng.uniform(*REGION[0]), rng.uniform(*REGION[1])])
        yaw = rng.uniform(-np.pi / 8, np.pi / 8)
        sim.set_free_pose("ball_joint", np.r_[xy, TABLE_TOP_Z + BALL_RADIUS], Rotation.from_euler("z", yaw).as_quat())
        colour = self.pick_colours(rng, 1)[0]
        sim.set_rgb("ball_geom", self.palette[colour])
        self.episode = {"colour": colour}

    def instruction(self) -> str:
        return "lift the ball"

    def evaluate_success(self, sim: SimHandle) -> bool:
        return bool(sim.body_pos("ball")[2] > TABLE_TOP_Z + BALL_RADIUS + LIFTED_BY)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"left": ["ball"], "right": ["ball"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return squeeze_and_lift(sim.body_pos("ball"))


def squeeze_and_lift(centre: np.ndarray) -> list[Keyframe]:
    """Both hands beside the ball (the left on its +y side), squeeze it and lift it."""
    side = {"left": 1.0, "right": -1.0}
    quat = down_quat(np.pi / 2)  # fingers along x: the hand's thin side faces the ball

    def at(dy: float, dz: float) -> Keyframe:
        return {arm: ArmAction(centre + [0.0, s * dy, dz], quat, 0.0, 1.0) for arm, s in side.items()}

    r = BALL_RADIUS + 0.02  # fingers beside the ball, clear of it
    return [at(r, 0.12), at(r, 0.0), at(BALL_RADIUS - SQUEEZE, 0.0), at(BALL_RADIUS - SQUEEZE, LIFTED_BY + 0.06)]
