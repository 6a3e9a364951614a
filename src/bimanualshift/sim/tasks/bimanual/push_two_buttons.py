"""Push two buttons: three buttons of different colours; both arms press the two the instruction names."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.props.buttons import (
    button_xml,
    buttons_by_side,
    latch_presses,
    place_button,
    press_keyframes,
    tops_by_side,
)
from bimanualshift.sim.props.placement import sample_separated
from bimanualshift.sim.task import Keyframe, SimHandle, Task, register_task

BUTTONS = ("button_0", "button_1", "button_2")
# Reachable regions ((x range), (y range)): left side, right side, anywhere (the third button).
LEFT_REGION = ((-0.10, 0.12), (0.12, 0.42))
RIGHT_REGION = ((-0.10, 0.12), (-0.42, -0.12))
ANY_REGION = ((-0.10, 0.12), (-0.42, 0.42))


@register_task("push_two_buttons")
class PushTwoButtons(Task):
    bimanual = True
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)

    def scene_xml(self) -> str:
        return "".join(button_xml(b, square=self.perturbations.unseen_shapes) for b in BUTTONS)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        colours = self.pick_colours(rng, 3)
        xy = sample_separated(rng, [LEFT_REGION, RIGHT_REGION, ANY_REGION], min_distance=0.13)
        for name, colour, p in zip(BUTTONS, colours, xy):
            place_button(sim, name, p)
            sim.set_rgb(f"{name}_cap", self.palette[colour])
        # button_0 is on the left side and button_1 on the right: each arm presses the one on its side.
        named = [0, 1] if rng.random() < 0.5 else [1, 0]  # the order the instruction names them in
        self.episode = {
            "colours": colours,
            "named": named,
            "pressed": [False, False, False],
        }

    def instruction(self) -> str:
        c = self.episode["colours"]
        a, b = self.episode["named"]
        return f"push the {c[a]} and the {c[b]} buttons"

    def on_control_step(self, sim: SimHandle) -> None:
        latch_presses(sim, BUTTONS, self.episode["pressed"])

    def evaluate_success(self, sim: SimHandle) -> bool:
        return all(self.episode["pressed"][i] for i in self.episode["named"])

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {arm: [b] for arm, b in buttons_by_side(sim, BUTTONS[0], BUTTONS[1]).items()}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        # Each arm presses the named button on its side (the layout may be mirrored).
        return press_keyframes(tops_by_side(sim, BUTTONS[0], BUTTONS[1]))

