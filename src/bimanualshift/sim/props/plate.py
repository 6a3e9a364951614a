"""A plate: a flat disc on a short foot with a raised rim that a gripper can pinch.

The rim is a ring of thin wall segments (a square rim as the unseen shape). A gripper pointing down with
its fingers opening radially straddles the rim: one finger over the plate, one outside it.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.mjcf import free_body
from bimanualshift.sim.task import SimHandle, Task

FOOT_HEIGHT = 0.010
FLOOR_HALF = 0.003
RIM_HEIGHT = 0.032  # rim top above the table
RIM_HALF_WIDTH = 0.003
SEGMENTS = 20


def plate_floor_top() -> float:
    return TABLE_TOP_Z + FOOT_HEIGHT + 2 * FLOOR_HALF


def plate_xml(name: str, radius: float, square: bool = False, mass: float = 0.15) -> str:
    floor_z = FOOT_HEIGHT + FLOOR_HALF
    wall_half_h = (RIM_HEIGHT - FOOT_HEIGHT) / 2
    wall_z = FOOT_HEIGHT + wall_half_h
    geoms = [f'<geom name="{name}_foot" type="cylinder" size="{radius * 0.5} {FOOT_HEIGHT / 2}" '
             f'pos="0 0 {FOOT_HEIGHT / 2}" group="1" rgba="1 1 1 1"/>']
    if square:
        geoms.append(f'<geom name="{name}_geom" type="box" size="{radius} {radius} {FLOOR_HALF}" pos="0 0 {floor_z}" '
                     f'group="1" rgba="1 1 1 1"/>')
        for i, (x, y, hx, hy) in enumerate([(radius, 0, RIM_HALF_WIDTH, radius), (-radius, 0, RIM_HALF_WIDTH, radius),
                                            (0, radius, radius, RIM_HALF_WIDTH), (0, -radius, radius, RIM_HALF_WIDTH)]):
            geoms.append(f'<geom name="{name}_rim{i}" type="box" size="{hx} {hy} {wall_half_h}" '
                         f'pos="{x} {y} {wall_z}" group="1" rgba="1 1 1 1"/>')
    else:
        geoms.append(f'<geom name="{name}_geom" type="cylinder" size="{radius} {FLOOR_HALF}" pos="0 0 {floor_z}" '
                     f'group="1" rgba="1 1 1 1"/>')
        half_len = radius * np.tan(np.pi / SEGMENTS) + RIM_HALF_WIDTH
        for i in range(SEGMENTS):
            a = 2 * np.pi * i / SEGMENTS
            geoms.append(
                f'<geom name="{name}_rim{i}" type="box" size="{RIM_HALF_WIDTH} {half_len:.4f} {wall_half_h}" '
                f'pos="{radius * np.cos(a):.4f} {radius * np.sin(a):.4f} {wall_z}" euler="0 0 {a:.4f}" '
                f'group="1" rgba="1 1 1 1"/>'
            )
    inertia = 0.25 * mass * radius**2
    return free_body(name, TABLE_TOP_Z, geoms, mass, (inertia, inertia, 2 * inertia), com_z=floor_z)



class PlateLiftTask(Task):
    """The hooks both plate tasks share: a plate named ``plate`` placed flat in ``region`` at a random yaw and
    coloured from the palette, lifted by ``lifted_by`` to succeed."""

    region: ClassVar[tuple[tuple[float, float], tuple[float, float]]]
    yaw_range: ClassVar[tuple[float, float]]  # the plate's random turn about the vertical (radians)
    lifted_by: ClassVar[float]  # metres the plate must rise

    def sample_xy(self, rng: np.random.Generator) -> np.ndarray:
        return np.array([rng.uniform(*self.region[0]), rng.uniform(*self.region[1])])

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        xy = self.sample_xy(rng)
        yaw = rng.uniform(*self.yaw_range)
        sim.set_free_pose("plate_joint", np.r_[xy, TABLE_TOP_Z], Rotation.from_euler("z", yaw).as_quat())
        colour = self.pick_colours(rng, 1)[0]
        sim.set_rgb_prefix("plate_", self.palette[colour])
        self.episode = {"colour": colour}

    def instruction(self) -> str:
        return "pick up the plate"

    def evaluate_success(self, sim: SimHandle) -> bool:
        return bool(sim.body_pos("plate")[2] > TABLE_TOP_Z + self.lifted_by)

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {arm: ["plate"] for arm in self.arm_names}
