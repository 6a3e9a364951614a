"""A dustpan, a brush and dirt.

Dustpan frame: origin at the centre of the mouth on the table, x pointing out of the mouth, z up; the floor
runs back to x = -PAN_LENGTH, the handle sticks out behind the back wall. The floor and its front ramp are a
jointless child body that ignores the table (they lie flush with it), so dirt pushed at the mouth rides up
a 2 mm ramp instead of stopping at a step; the walls stand on the table.

Brush frame: origin under the head's centre; the head is long along x; the stick is square so a pinch on
two faces holds it against the push.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.placement import sample_separated
from bimanualshift.sim.task import SimHandle, Task

PAN_LENGTH, PAN_WIDTH = 0.12, 0.20
PAN_WALL_HEIGHT = 0.04
PAN_FLOOR = 0.0015
HANDLE_LENGTH, HANDLE_RADIUS, HANDLE_Z = 0.10, 0.008, 0.03
HANDLE_GRASP_X = -PAN_LENGTH - 0.07

BRUSH_HEAD_HALF = (0.08, 0.012, 0.015)
BRUSH_STICK_HALF = (0.008, 0.008, 0.045)
BRUSH_STICK_TOP = 2 * BRUSH_HEAD_HALF[2] + 2 * BRUSH_STICK_HALF[2]

DIRT_HALF = 0.007


def dustpan_xml(name: str) -> str:
    look = 'group="1" rgba="1 1 1 1"'
    wall_half_h = PAN_WALL_HEIGHT / 2
    ramp_len = 0.03
    ramp_angle = np.arctan2(PAN_FLOOR + 0.001, ramp_len)  # about 5 degrees
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z}">
  <freejoint name="{name}_joint"/>
  <inertial pos="{-PAN_LENGTH / 2} 0 0.01" mass="0.3" diaginertia="0.002 0.001 0.003"/>
  <geom name="{name}_back" type="box" size="0.003 {PAN_WIDTH / 2} {wall_half_h}" pos="{-PAN_LENGTH} 0 {wall_half_h}"
        {look}/>
  <geom name="{name}_side0" type="box" size="{PAN_LENGTH / 2} 0.003 {wall_half_h}"
        pos="{-PAN_LENGTH / 2} {PAN_WIDTH / 2} {wall_half_h}" {look}/>
  <geom name="{name}_side1" type="box" size="{PAN_LENGTH / 2} 0.003 {wall_half_h}"
        pos="{-PAN_LENGTH / 2} {-PAN_WIDTH / 2} {wall_half_h}" {look}/>
  <geom name="{name}_handle" type="capsule" size="{HANDLE_RADIUS} {HANDLE_LENGTH / 2}"
        pos="{-PAN_LENGTH - HANDLE_LENGTH / 2} 0 {HANDLE_Z}" euler="0 1.5708 0" {look}/>
  <geom name="{name}_post" type="box" size="0.006 0.01 {HANDLE_Z / 2}" pos="{-PAN_LENGTH - 0.01} 0 {HANDLE_Z / 2}"
        {look}/>
  <body name="{name}_floor">
    <geom name="{name}_floor" type="box" size="{PAN_LENGTH / 2} {PAN_WIDTH / 2} {PAN_FLOOR / 2}"
          pos="{-PAN_LENGTH / 2} 0 {PAN_FLOOR / 2}" friction="0.2 0.005 0.0001" {look}/>
    <geom name="{name}_ramp" type="box" size="{ramp_len / 2} {PAN_WIDTH / 2} 0.001"
          pos="{ramp_len / 2} 0 {PAN_FLOOR / 2 - 0.0005}" euler="0 {ramp_angle:.4f} 0" friction="0.2 0.005 0.0001"
          {look}/>
  </body>
</body>
<contact><exclude body1="{name}_floor" body2="table"/></contact>"""


def brush_xml(name: str, round_stick: bool = False) -> str:
    look = 'group="1" rgba="1 1 1 1"'
    hx, hy, hz = BRUSH_HEAD_HALF
    sx, _, sz = BRUSH_STICK_HALF
    stick = (f'type="cylinder" size="{sx} {sz}"' if round_stick else
             f'type="box" size="{sx} {BRUSH_STICK_HALF[1]} {sz}"')
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z}">
  <freejoint name="{name}_joint"/>
  <inertial pos="0 0 {hz}" mass="0.15" diaginertia="0.0004 0.0003 0.0004"/>
  <geom name="{name}_geom" type="box" size="{hx} {hy} {hz}" pos="0 0 {hz}" friction="0.3 0.005 0.0001" {look}/>
  <geom name="{name}_stick" {stick} pos="0 0 {2 * hz + sz}" friction="1.5 0.005 0.0001" {look}/>
</body>"""


def dirt_xml(name: str) -> str:
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z + DIRT_HALF}">
  <freejoint name="{name}_joint"/>
  <inertial pos="0 0 0" mass="0.01" diaginertia="3e-7 3e-7 3e-7"/>
  <geom name="{name}_geom" type="box" size="{DIRT_HALF} {DIRT_HALF} {DIRT_HALF}" friction="0.3 0.005 0.0001"
        group="1" rgba="0.45 0.3 0.15 1"/>
</body>"""


PAN_MOUTH = ((-0.02, 0.08), (0.06, 0.10))  # x, y of the mouth's centre; the pan faces -y (towards the dirt)
PAN_TURN = 0.15  # radians either side of facing straight at the dirt
BRUSH_Y = (-0.30, -0.25)
DIRT_ALONG = (0.05, 0.19)  # dirt distance in front of the mouth
DIRT_ACROSS = 0.045  # dirt offset across the sweep, either side of the pan's centre line


def place_sweep_scene(sim: SimHandle, rng: np.random.Generator, pan: str, brush: str, dirt: tuple[str, ...],
                      shift_y: float = 0.0) -> None:
    """Dustpan facing -y, dirt scattered in front of its mouth, the brush beyond the dirt; everything
    ``shift_y`` to the side."""
    mouth = np.array([rng.uniform(*PAN_MOUTH[0]), rng.uniform(*PAN_MOUTH[1]) + shift_y])
    pan_yaw = -np.pi / 2 + rng.uniform(-PAN_TURN, PAN_TURN)  # the pan's x (out of the mouth) towards -y
    sim.set_free_pose(f"{pan}_joint", np.r_[mouth, TABLE_TOP_Z], Rotation.from_euler("z", pan_yaw).as_quat())
    out = np.array([np.cos(pan_yaw), np.sin(pan_yaw)])
    across = np.array([-out[1], out[0]])
    regions = [(DIRT_ALONG, (-DIRT_ACROSS, DIRT_ACROSS))] * len(dirt)
    for name, (a, c) in zip(dirt, sample_separated(rng, regions, min_distance=0.025)):
        sim.set_free_pose(f"{name}_joint", np.r_[mouth + a * out + c * across, TABLE_TOP_Z + DIRT_HALF],
                          Rotation.from_euler("z", rng.uniform(0, np.pi / 2)).as_quat())
    brush_xy = np.array([mouth[0] + rng.uniform(-0.03, 0.03), rng.uniform(*BRUSH_Y) + shift_y])
    sim.set_free_pose(f"{brush}_joint", np.r_[brush_xy, TABLE_TOP_Z],
                      Rotation.from_euler("z", rng.uniform(-0.15, 0.15)).as_quat())


def dirt_in_pan(sim: SimHandle, pan: str, dirt: tuple[str, ...]) -> bool:
    """Whether every piece of dirt lies over the pan's floor."""
    body = sim.body_id(pan)
    origin, rotation = sim.data.xpos[body], Rotation.from_matrix(sim.data.xmat[body].reshape(3, 3))
    for name in dirt:
        x, y, _ = rotation.inv().apply(sim.body_pos(name) - origin)
        if not (-PAN_LENGTH < x < -DIRT_HALF and abs(y) < PAN_WIDTH / 2 - DIRT_HALF):
            return False
    return True


SWEEP_DIRT = tuple(f"dirt_{i}" for i in range(5))


class SweepTask(Task):
    """The hooks both sweeping tasks share: a dustpan, a brush and five dirt cubes placed by
    ``place_sweep_scene``; every dirt cube in the pan to succeed."""

    def scene_xml(self) -> str:
        return (dustpan_xml("dustpan") + brush_xml("brush", round_stick=self.perturbations.unseen_shapes)
                + "".join(dirt_xml(d) for d in SWEEP_DIRT))

    def instance_class(self, instance: str) -> str:
        return "dirt" if instance.startswith("dirt") else instance

    def goal_nouns(self) -> list[str]:
        return ["dirt", "dustpan", "brush"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        return dirt_in_pan(sim, "dustpan", SWEEP_DIRT)
