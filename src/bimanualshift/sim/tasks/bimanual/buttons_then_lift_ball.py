"""Long horizon: both arms press the two buttons the instruction names, then squeeze the ball between them and
lift it. A four-stage composite of `push_two_buttons` and `lift_ball` for the continual-learning study: each
stage is judged on its own, so a run reports how far along the chain a method gets."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.ball import BALL_RADIUS, ball_xml
from bimanualshift.sim.props.buttons import (
    button_xml,
    buttons_by_side,
    latch_presses,
    place_button,
    press_keyframes,
    tops_by_side,
)
from bimanualshift.sim.task import Keyframe, SimHandle, Task, register_task
from bimanualshift.sim.tasks.bimanual.lift_ball import LIFTED_BY, squeeze_and_lift

BUTTONS = ("button_0", "button_1")
# The buttons stand well outside the arms' path to the ball: button_0 on the left, button_1 on the right.
BUTTON_REGIONS = (((-0.10, 0.12), (0.28, 0.42)), ((-0.10, 0.12), (-0.42, -0.28)))
BALL_REGION = ((-0.06, 0.10), (-0.04, 0.04))
OFF_TABLE_BY = 0.02  # metres the ball's centre must rise for the "ball grasped" stage


@register_task("buttons_then_lift_ball")
class ButtonsThenLiftBall(Task):
    bimanual = True
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)
    stage_names = ("first button", "both buttons", "ball grasped", "ball lifted")

    def scene_xml(self) -> str:
        square = self.perturbations.unseen_shapes
        return "".join(button_xml(b, square=square) for b in BUTTONS) + ball_xml("ball", cube=square)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        colours = self.pick_colours(rng, 3)  # two buttons and the ball
        for name, colour, (xr, yr) in zip(BUTTONS, colours, BUTTON_REGIONS):
            place_button(sim, name, np.array([rng.uniform(*xr), rng.uniform(*yr)]))
            sim.set_rgb(f"{name}_cap", self.palette[colour])
        xy = np.array([rng.uniform(*BALL_REGION[0]), rng.uniform(*BALL_REGION[1])])
        yaw = rng.uniform(-np.pi / 8, np.pi / 8)
        sim.set_free_pose("ball_joint", np.r_[xy, TABLE_TOP_Z + BALL_RADIUS], Rotation.from_euler("z", yaw).as_quat())
        sim.set_rgb("ball_geom", self.palette[colours[2]])
        named = [0, 1] if rng.random() < 0.5 else [1, 0]
        self.episode = {"colours": colours, "named": named, "pressed": [False, False]}

    def instruction(self) -> str:
        c = self.episode["colours"]
        a, b = self.episode["named"]
        return f"push the {c[a]} and the {c[b]} buttons, then lift the ball"

    def on_control_step(self, sim: SimHandle) -> None:
        latch_presses(sim, BUTTONS, self.episode["pressed"])

    def _ball_rise(self, sim: SimHandle) -> float:
        return float(sim.body_pos("ball")[2] - (TABLE_TOP_Z + BALL_RADIUS))

    def evaluate_stages(self, sim: SimHandle) -> list[bool]:
        pressed = sum(self.episode["pressed"])
        rise = self._ball_rise(sim)
        return [pressed >= 1, pressed == 2, rise > OFF_TABLE_BY, rise > LIFTED_BY]

    def evaluate_success(self, sim: SimHandle) -> bool:
        return all(self.episode["pressed"]) and self._ball_rise(sim) > LIFTED_BY

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {arm: [b, "ball"] for arm, b in buttons_by_side(sim, *BUTTONS).items()}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        # Each arm presses the button on its side (a mirrored layout swaps them).
        return press_keyframes(tops_by_side(sim, *BUTTONS)) + squeeze_and_lift(sim.body_pos("ball"))
