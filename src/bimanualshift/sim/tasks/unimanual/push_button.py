"""Single arm: push the button of the named colour among one to three buttons."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.props.buttons import (
    BUTTON_PRESSED_AT,
    button_top,
    button_travel,
    button_xml,
    place_button,
    press_keyframes,
)
from bimanualshift.sim.props.placement import sample_separated
from bimanualshift.sim.task import Keyframe, SimHandle, Task, register_task

BUTTONS = ("button_0", "button_1", "button_2")
REGION = ((-0.10, 0.15), (-0.32, 0.32))
PARKED = np.array([1.5, 0.0])  # unused buttons are parked off the table, out of every camera's view


@register_task("push_button")
class PushButton(Task):
    bimanual = False
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)

    def scene_xml(self) -> str:
        return "".join(button_xml(b, square=self.perturbations.unseen_shapes) for b in BUTTONS)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        n = int(rng.integers(1, len(BUTTONS) + 1))
        colours = self.pick_colours(rng, len(BUTTONS))
        xy = sample_separated(rng, [REGION] * n, min_distance=0.13)
        for i, name in enumerate(BUTTONS):
            place_button(sim, name, xy[i] if i < n else PARKED + [0.0, 0.2 * i])
            sim.set_rgb(f"{name}_cap", self.palette[colours[i]])
        self.episode = {"colours": colours, "count": n, "target": int(rng.integers(n)), "pressed": False}

    def instruction(self) -> str:
        return f"push the {self.episode['colours'][self.episode['target']]} button"

    def on_control_step(self, sim: SimHandle) -> None:
        if button_travel(sim, BUTTONS[self.episode["target"]]) >= BUTTON_PRESSED_AT:
            self.episode["pressed"] = True

    def evaluate_success(self, sim: SimHandle) -> bool:
        return bool(self.episode["pressed"])

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": [BUTTONS[self.episode["target"]]]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return press_keyframes({"right": button_top(sim, BUTTONS[self.episode["target"]])})
