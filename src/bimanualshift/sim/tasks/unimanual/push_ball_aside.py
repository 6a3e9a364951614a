"""Single arm: push a large ball away to the side with the back of the closed hand.

The ball lies 0.18-0.42 m to one side of the arm, where ``lift_ball`` puts it in each arm's frame; the hand
comes down beside it on the side facing the arm's centre line, fingers along x, as each arm of ``lift_ball``
does before it squeezes, and pushes it outwards.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z, skill_side
from bimanualshift.sim.props.ball import BALL_RADIUS, ball_xml
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, Task, down_quat, register_task

REGION_X = (-0.08, 0.12)
SIDE_Y = (0.18, 0.42)
PUSHED_BY = 0.05  # metres outwards the ball must move
SQUEEZE = 0.025  # as lift_ball: the hand first presses this far inside the ball's radius
PUSH = 0.10  # then goes on this far inside it


@register_task("push_ball_aside")
class PushBallAside(Task):
    bimanual = False
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)
    added_skill = True

    def scene_xml(self) -> str:
        return ball_xml("ball", cube=self.perturbations.unseen_shapes)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        side = skill_side(rng)
        xy = np.array([rng.uniform(*REGION_X), side * rng.uniform(*SIDE_Y)])
        yaw = rng.uniform(-np.pi / 8, np.pi / 8)
        sim.set_free_pose("ball_joint", np.r_[xy, TABLE_TOP_Z + BALL_RADIUS], Rotation.from_euler("z", yaw).as_quat())
        colour = self.pick_colours(rng, 1)[0]
        sim.set_rgb("ball_geom", self.palette[colour])
        self.episode = {"colour": colour, "start_y": float(xy[1])}

    def instruction(self) -> str:
        return "push the ball away to the side"

    def evaluate_success(self, sim: SimHandle) -> bool:
        start = self.episode["start_y"]
        ball = sim.body_pos("ball")
        return bool((ball[1] - start) * np.sign(start) >= PUSHED_BY and ball[2] < TABLE_TOP_Z + 2 * BALL_RADIUS)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": ["ball"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        centre = sim.body_pos("ball")
        s = -np.sign(centre[1])  # the hand on the ball's side facing the arm's centre line
        quat = down_quat(np.pi / 2)  # fingers along x: the hand's thin side faces the ball

        def at(dy: float, dz: float) -> Keyframe:
            return {"right": ArmAction(centre + [0.0, s * dy, dz], quat, 0.0, 1.0)}

        r = BALL_RADIUS + 0.02
        return [at(r, 0.12), at(r, 0.0), at(BALL_RADIUS - SQUEEZE, 0.0), at(BALL_RADIUS - PUSH, 0.0)]
