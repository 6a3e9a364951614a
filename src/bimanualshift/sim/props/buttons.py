"""Push buttons: a housing and a spring-loaded cap on a slide joint, and the expert's press keyframes."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.task import DOWN_QUAT, ArmAction, Keyframe, SimHandle

BUTTON_RADIUS = 0.035
BUTTON_TRAVEL = 0.015
BUTTON_PRESSED_AT = 0.008  # joint travel (m) that counts as a press
BUTTON_TOP = 0.02 + 0.024  # cap top above the table when released


def button_xml(name: str, square: bool = False) -> str:
    """A push button: a grey housing and a spring-loaded coloured cap on a vertical slide joint."""
    cap = (f'type="box" size="{BUTTON_RADIUS * 0.9} {BUTTON_RADIUS * 0.9} 0.012"' if square
           else f'type="cylinder" size="{BUTTON_RADIUS} 0.012"')
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z}">
  <geom name="{name}_housing" type="cylinder" size="0.045 0.01" pos="0 0 0.01" rgba="0.35 0.35 0.38 1"
        group="1" friction="1 0.005 0.0001"/>
  <body name="{name}_cap" pos="0 0 0.02">
    <joint name="{name}_joint" type="slide" axis="0 0 1" range="-{BUTTON_TRAVEL} 0" limited="true"
           stiffness="40" springref="0" damping="1"/>
    <inertial pos="0 0 0.012" mass="0.05" diaginertia="2e-5 2e-5 3e-5"/>
    <geom name="{name}_cap" {cap} pos="0 0 0.012" rgba="1 0 0 1"
          group="1"/>
  </body>
</body>"""


def place_button(sim: SimHandle, name: str, xy: np.ndarray) -> None:
    sim.model.body_pos[sim.body_id(name)] = (xy[0], xy[1], TABLE_TOP_Z)
    sim.joint_qpos(f"{name}_joint")[:] = 0.0
    sim.joint_qvel(f"{name}_joint")[:] = 0.0


def button_travel(sim: SimHandle, name: str) -> float:
    return float(-sim.joint_qpos(f"{name}_joint")[0])


def button_top(sim: SimHandle, name: str) -> np.ndarray:
    pos = sim.model.body_pos[sim.body_id(name)].copy()
    pos[2] = TABLE_TOP_Z + BUTTON_TOP
    return pos


def press_keyframes(tops: dict[str, np.ndarray]) -> list[Keyframe]:
    """Above the button with the gripper closed, press down through the cap's travel, back up.

    The press target lies 2.5 cm below the released cap top, beyond the 1.5 cm travel: the cap bottoms
    out, so a policy whose target is a centimetre too high (one voxel) still presses the button.
    """
    frames: list[Keyframe] = []
    for dz in (0.08, -0.025, 0.08):
        frames.append({arm: ArmAction(top + [0, 0, dz], DOWN_QUAT, 0.0, 0.0) for arm, top in tops.items()})
    return frames


def latch_presses(sim: SimHandle, names: tuple[str, ...] | list[str], pressed: list[bool]) -> None:
    """Mark every button pressed past ``BUTTON_PRESSED_AT`` (a press once made stays made)."""
    for i, name in enumerate(names):
        if button_travel(sim, name) >= BUTTON_PRESSED_AT:
            pressed[i] = True


def buttons_by_side(sim: SimHandle, first: str, second: str) -> dict[str, str]:
    """The two buttons' names, each given to the arm on its side (larger y: left; a mirrored layout swaps them)."""
    left_first = button_top(sim, first)[1] > button_top(sim, second)[1]
    return {"left": first, "right": second} if left_first else {"left": second, "right": first}


def tops_by_side(sim: SimHandle, first: str, second: str) -> dict[str, np.ndarray]:
    """The two buttons' tops, each given to the arm on its side (larger y: left; a mirrored layout swaps them)."""
    a, b = button_top(sim, first), button_top(sim, second)
    return {"left": a, "right": b} if a[1] > b[1] else {"left": b, "right": a}
