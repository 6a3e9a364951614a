"""A light toaster with one bread slot, a handle and a spring-loaded lever, a slice of bread standing in a rack,
and the lever's latch.

The toaster's long axis is its y. The handle sticks out of its +y end, the lever out of its -y end. The toaster
weighs 100 g, and the lever's spring pushes back harder the further it goes. Pressed on its own, the toaster rocks
over its lever end, by 12-13 degrees on the scripted press; with a second hand on the handle it tilts 2-3 degrees
(``benchmarks/investigations/toaster_rock.py``). Keeping it steady is the coordination the paper's Toaster
Activation asks for.

Once the lever passes ``LATCH_AT``, it latches: its joint range then stops it from rising again, and the bread
turns to toast. ``hold_latch`` applies this each control step, from the flag in the task's episode state, so a
restored state puts the range back too. A mounted toaster (for the single-arm skills) is fixed to the table."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.task import SimHandle

HALF_X, HALF_Y, HEIGHT = 0.06, 0.10, 0.12  # the body: 12 x 20 cm, 12 cm tall
SLOT_HALF_X, SLOT_HALF_Y = 0.018, 0.056  # the slot's opening: 3.6 x 11.2 cm
SLOT_FLOOR = 0.07  # above the table: a slice stands 5 cm deep in the slot and 4 cm out of it
HANDLE = (0.012, 0.025, 0.025)  # half sizes of the handle on the +y end (x, y, z), its top level with the toaster's
LEVER = (0.018, 0.035, 0.006)  # half sizes of the lever tab on the -y end: 7 cm out, so a press rocks the toaster
LEVER_TOP = 0.10  # the tab's centre above the table when released
LEVER_TRAVEL = 0.05
LATCH_AT = 0.04  # travel at which the lever latches
LEVER_STIFFNESS = 300.0  # N/m: 12 N at the latch, more than the toaster's weight holds down off its end
TOASTER_MASS = 0.10
BREAD = (0.008, 0.045, 0.045)  # half sizes of the slice: 1.6 cm thick (x), 9 x 9 cm
BREAD_COLOUR = (0.93, 0.85, 0.62)
TOAST_COLOUR = (0.62, 0.38, 0.16)
RACK_HEIGHT = 0.012  # the rack's bars stand this tall; the slice stands on the table between them


def toaster_xml(name: str = "toaster", mounted: bool = False) -> str:
    """The toaster standing on the table; ``mounted``, fixed there (placed per episode through its body pose)."""
    wall_x = (HALF_X - SLOT_HALF_X) / 2  # the two long walls beside the slot
    end_y = (HALF_Y - SLOT_HALF_Y) / 2  # the two end walls
    upper = (HEIGHT - SLOT_FLOOR) / 2  # half height of the walls above the slot's floor
    style = 'group="1" rgba="0.75 0.75 0.78 1" friction="1 0.005 0.0001"'
    geoms = [
        f'<geom name="{name}_base" type="box" size="{HALF_X} {HALF_Y} {SLOT_FLOOR / 2}" pos="0 0 {SLOT_FLOOR / 2}" '
        f'{style}/>',
        *(f'<geom name="{name}_wall{i}" type="box" size="{wall_x} {HALF_Y} {upper}" '
          f'pos="{s * (SLOT_HALF_X + wall_x)} 0 {SLOT_FLOOR + upper}" {style}/>' for i, s in enumerate((1, -1))),
        *(f'<geom name="{name}_end{i}" type="box" size="{SLOT_HALF_X} {end_y} {upper}" '
          f'pos="0 {s * (SLOT_HALF_Y + end_y)} {SLOT_FLOOR + upper}" {style}/>' for i, s in enumerate((1, -1))),
        f'<geom name="{name}_handle" type="box" size="{HANDLE[0]} {HANDLE[1]} {HANDLE[2]}" '
        f'pos="0 {HALF_Y + HANDLE[1]} {HEIGHT - HANDLE[2]}" group="1" rgba="0.2 0.2 0.22 1" '
        'friction="1.5 0.005 0.0001"/>',
    ]
    joint = "" if mounted else f'<freejoint name="{name}_joint"/>'
    inertial = "" if mounted else (f'<inertial pos="0 0 {HEIGHT / 2}" mass="{TOASTER_MASS}" '
                                   f'diaginertia="6e-4 3e-4 6e-4"/>')
    lever_y = -HALF_Y - LEVER[1]
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z}">
  {joint}{inertial}
  {"".join(geoms)}
  <body name="{name}_lever" pos="0 {lever_y} {LEVER_TOP}">
    <joint name="{name}_lever_joint" type="slide" axis="0 0 1" range="-{LEVER_TRAVEL} 0" limited="true"
           solreflimit="0.004 1" stiffness="{LEVER_STIFFNESS}" springref="0" damping="2"/>
    <inertial pos="0 0 0" mass="0.02" diaginertia="4e-6 4e-6 4e-6"/>
    <geom name="{name}_lever_geom" type="box" size="{LEVER[0]} {LEVER[1]} {LEVER[2]}" group="1"
          rgba="0.1 0.1 0.1 1" friction="1 0.005 0.0001"/>
  </body>
</body>"""


def bread_xml(name: str = "bread") -> str:
    """A slice of bread, standing upright (its faces along x)."""
    x, y, z = BREAD
    r, g, b = BREAD_COLOUR
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z + z}">
  <freejoint name="{name}_joint"/>
  <inertial pos="0 0 0" mass="0.03" diaginertia="2e-5 1e-5 1e-5"/>
  <geom name="{name}_geom" type="box" size="{x} {y} {z}" group="1" rgba="{r} {g} {b} 1"
        friction="1 0.005 0.0001" condim="4"/>
</body>"""


def rack_xml(name: str = "rack") -> str:
    """Two low bars on a plate that keep the slice standing (fixed to the table; placed per episode)."""
    gap = BREAD[0] + 0.003
    bar = f'type="box" size="0.005 0.05 {RACK_HEIGHT / 2}" group="1" rgba="0.45 0.3 0.2 1"'
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z}">
  <geom name="{name}_bar0" {bar} pos="{gap + 0.005} 0 {RACK_HEIGHT / 2}"/>
  <geom name="{name}_bar1" {bar} pos="{-gap - 0.005} 0 {RACK_HEIGHT / 2}"/>
</body>"""


def yaw_of(sim: SimHandle, body: str) -> float:
    return float(Rotation.from_matrix(sim.data.xmat[sim.body_id(body)].reshape(3, 3)).as_euler("xyz")[2])


def place_toaster(sim: SimHandle, xy: np.ndarray, yaw: float, mounted: bool = False, name: str = "toaster") -> None:
    quat = Rotation.from_euler("z", yaw).as_quat()
    if mounted:
        body = sim.body_id(name)
        sim.model.body_pos[body] = (xy[0], xy[1], TABLE_TOP_Z)
        sim.model.body_quat[body] = np.roll(quat, 1)
    else:
        sim.set_free_pose(f"{name}_joint", np.r_[xy, TABLE_TOP_Z + 0.001], quat)
    sim.joint_qpos(f"{name}_lever_joint")[:] = 0.0
    sim.joint_qvel(f"{name}_lever_joint")[:] = 0.0


def place_bread_in_rack(sim: SimHandle, xy: np.ndarray, yaw: float) -> None:
    """The rack at ``xy`` turned by ``yaw``, the slice standing in it."""
    rack = sim.body_id("rack")
    sim.model.body_pos[rack] = (xy[0], xy[1], TABLE_TOP_Z)
    sim.model.body_quat[rack] = np.roll(Rotation.from_euler("z", yaw).as_quat(), 1)
    sim.set_free_pose("bread_joint", np.r_[xy, TABLE_TOP_Z + BREAD[2] + 0.001], Rotation.from_euler("z", yaw).as_quat())


def place_bread_in_slot(sim: SimHandle, xy: np.ndarray, yaw: float) -> None:
    """The slice standing on the floor of the slot of a toaster at ``xy`` turned by ``yaw`` (one that has just
    toasted it)."""
    sim.set_free_pose("bread_joint", np.r_[xy, TABLE_TOP_Z + SLOT_FLOOR + BREAD[2] + 0.001],
                      Rotation.from_euler("z", yaw).as_quat())


def in_frame(sim: SimHandle, body: str, point: np.ndarray) -> np.ndarray:
    """``point`` (world) in ``body``'s frame."""
    return sim.data.xmat[sim.body_id(body)].reshape(3, 3).T @ (point - sim.data.xpos[sim.body_id(body)])


def to_world(sim: SimHandle, body: str, local: np.ndarray) -> np.ndarray:
    return sim.data.xpos[sim.body_id(body)] + sim.data.xmat[sim.body_id(body)].reshape(3, 3) @ np.asarray(local)


def lever_travel(sim: SimHandle, name: str = "toaster") -> float:
    return float(-sim.joint_qpos(f"{name}_lever_joint")[0])


def hold_latch(sim: SimHandle, latched: bool, name: str = "toaster") -> bool:
    """Latch the lever once it passes ``LATCH_AT`` (and keep it latched); returns whether it is latched. The bread
    turns to toast when it latches."""
    latched = latched or lever_travel(sim, name) >= LATCH_AT
    joint = sim.model.joint(f"{name}_lever_joint").id
    sim.model.jnt_range[joint] = (-LEVER_TRAVEL, -LATCH_AT + 0.002) if latched else (-LEVER_TRAVEL, 0.0)
    return latched


def toaster_upright(sim: SimHandle, name: str = "toaster", within_deg: float = 10.0) -> bool:
    up = sim.data.xmat[sim.body_id(name)].reshape(3, 3)[:, 2]
    return bool(up[2] > np.cos(np.deg2rad(within_deg)))


def bread_in_slot(sim: SimHandle, name: str = "toaster", depth: float = 0.03) -> bool:
    """Whether the slice stands in the slot, its bottom at least ``depth`` below the toaster's top."""
    local = in_frame(sim, name, sim.body_pos("bread"))
    inside = abs(local[0]) < SLOT_HALF_X and abs(local[1]) < SLOT_HALF_Y
    return bool(inside and local[2] - BREAD[2] < HEIGHT - depth)
