"""An oven with a bottom-hinged door and a tray with a pull tab.

Geometry lives in the oven's own frame: the origin is the bottom-centre of the oven's mouth on the table,
x points into the oven (away from the robots), z up. The door hangs from a hinge along the mouth's bottom
edge; it falls open under gravity once pulled past a few degrees (its joint friction holds it shut until
then) and stops level with the oven floor, so an opened door is a shelf the tray slides onto.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.mjcf import free_body
from bimanualshift.sim.task import SimHandle

PLINTH = 0.04  # oven floor (and hinge) height above the table
DEPTH, WIDTH, HEIGHT = 0.26, 0.36, 0.30  # interior
WALL = 0.01
DOOR_THICKNESS = 0.012
HANDLE_HEIGHT = HEIGHT - 0.03  # bar height along the door, from the hinge
HANDLE_OFFSET = 0.045  # bar centre in front of the door's outer face
HANDLE_RADIUS = 0.007
HANDLE_HALF_LENGTH = 0.09

TRAY_HALF = (0.09, 0.13)  # x, y
TRAY_FLOOR_HALF = 0.003
TRAY_LIP_HEIGHT = 0.02
# The pull tab on the tray's front edge: thin along y for a gripper, tall enough that fingers reaching it
# from the front pass over the tray's lip.
TAB_HALF = (0.012, 0.006, 0.03)
TAB_X = -TRAY_HALF[0] + 0.02  # tab centre in the tray's frame


def oven_xml(name: str) -> str:
    inner_top = PLINTH + HEIGHT
    box = 'type="box" group="1" rgba="0.55 0.55 0.58 1"'
    half_w = WIDTH / 2 + WALL
    geoms = [
        f'<geom name="{name}_plinth" {box} size="{DEPTH / 2} {half_w} {PLINTH / 2}" '
        f'pos="{DEPTH / 2 + 0.002} 0 {PLINTH / 2}"/>',
        f'<geom name="{name}_top" {box} size="{DEPTH / 2} {half_w} {WALL / 2}" '
        f'pos="{DEPTH / 2 + 0.002} 0 {inner_top + WALL / 2}"/>',
        f'<geom name="{name}_back" {box} size="{WALL / 2} {half_w} {HEIGHT / 2 + WALL / 2}" '
        f'pos="{DEPTH + 0.002 + WALL / 2} 0 {PLINTH + HEIGHT / 2 + WALL / 2}"/>',
    ]
    for side, s in (("left", 1), ("right", -1)):
        geoms.append(f'<geom name="{name}_{side}" {box} size="{DEPTH / 2} {WALL / 2} {HEIGHT / 2}" '
                     f'pos="{DEPTH / 2 + 0.002} {s * (WIDTH / 2 + WALL / 2)} {PLINTH + HEIGHT / 2}"/>')
    door_box = 'type="box" group="1" rgba="0.25 0.25 0.28 1"'
    bar_x = -DOOR_THICKNESS - HANDLE_OFFSET
    posts = "".join(
        f'<geom name="{name}_door_post{i}" {door_box} size="{HANDLE_OFFSET / 2} 0.005 0.005" '
        f'pos="{-DOOR_THICKNESS - HANDLE_OFFSET / 2} {s * HANDLE_HALF_LENGTH} {HANDLE_HEIGHT}"/>'
        for i, s in enumerate((1, -1))
    )
    # Visual geoms (group 1) carry no mass in robosuite's compiler settings: inertias are explicit.
    # Parent and child bodies never collide in MuJoCo, so the door swings through the oven's front edge.
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z}">
  {"".join(geoms)}
  <body name="{name}_door" pos="0 0 {PLINTH}">
    <joint name="{name}_door_hinge" type="hinge" axis="0 -1 0" range="0 {np.pi / 2}" limited="true"
           frictionloss="0.12" damping="0.25" armature="0.002"/>
    <inertial pos="{-DOOR_THICKNESS / 2} 0 {HEIGHT / 2}" mass="0.8" diaginertia="0.0045 0.0045 0.009"/>
    <geom name="{name}_door_panel" {door_box} size="{DOOR_THICKNESS / 2} {half_w} {HEIGHT / 2}"
          pos="{-DOOR_THICKNESS / 2} 0 {HEIGHT / 2}"/>
    {posts}
    <geom name="{name}_door_handle" type="capsule" size="{HANDLE_RADIUS} {HANDLE_HALF_LENGTH}" group="1"
          rgba="0.8 0.8 0.82 1" pos="{bar_x} 0 {HANDLE_HEIGHT}" euler="1.5708 0 0"/>
  </body>
</body>"""


def tray_xml(name: str, round_tray: bool = False) -> str:
    hx, hy = TRAY_HALF
    lip_half = TRAY_LIP_HEIGHT / 2
    z_lip = 2 * TRAY_FLOOR_HALF + lip_half
    look = 'group="1" rgba="1 1 1 1"'
    if round_tray:  # the unseen shape: a round tray without side lips
        geoms = [f'<geom name="{name}_geom" type="cylinder" size="{hy * 0.85} {TRAY_FLOOR_HALF}" '
                 f'pos="0 0 {TRAY_FLOOR_HALF}" {look}/>']
    else:
        geoms = [f'<geom name="{name}_geom" type="box" size="{hx} {hy} {TRAY_FLOOR_HALF}" pos="0 0 {TRAY_FLOOR_HALF}" '
                 f'{look}/>']
        for i, (x, y, sx, sy) in enumerate([(hx, 0, 0.003, hy), (-hx, 0, 0.003, hy), (0, hy, hx, 0.003),
                                            (0, -hy, hx, 0.003)]):
            geoms.append(f'<geom name="{name}_lip{i}" type="box" size="{sx} {sy} {lip_half}" pos="{x} {y} {z_lip}" '
                         f'{look}/>')
    geoms.append(f'<geom name="{name}_tab" type="box" size="{TAB_HALF[0]} {TAB_HALF[1]} {TAB_HALF[2]}" '
                 f'pos="{TAB_X} 0 {2 * TRAY_FLOOR_HALF + TAB_HALF[2]}" friction="1.5 0.005 0.0001" {look}/>')
    return free_body(name, TABLE_TOP_Z + 0.3, geoms, mass=0.3, inertia=(0.002, 0.001, 0.003), com_z=0.004)


class OvenFrame:
    """Converts points and gripper yaws between the oven's frame and the world."""

    def __init__(self, mouth_world: np.ndarray, yaw: float) -> None:
        self.origin = np.asarray(mouth_world, dtype=float)
        self.yaw = float(yaw)
        self.rotation = Rotation.from_euler("z", yaw)

    def to_world(self, local: np.ndarray) -> np.ndarray:
        return self.origin + self.rotation.apply(np.asarray(local, dtype=float))

    def to_local(self, world: np.ndarray) -> np.ndarray:
        return self.rotation.inv().apply(np.asarray(world, dtype=float) - self.origin)


def door_point(angle: float, along: float, out: float) -> np.ndarray:
    """A point of the door in the oven frame: ``along`` metres up the door from the hinge and ``out`` metres
    in front of its inner face, with the door opened by ``angle`` radians (0 shut, pi/2 level)."""
    up = np.array([-np.sin(angle), 0.0, np.cos(angle)])
    outward = np.array([-np.cos(angle), 0.0, -np.sin(angle)])
    return np.array([0.0, 0.0, PLINTH]) + along * up + out * outward


def oven_frame(sim: SimHandle, name: str) -> OvenFrame:
    body = sim.body_id(name)
    yaw = Rotation.from_quat(np.roll(sim.model.body_quat[body], -1)).as_euler("xyz")[2]
    return OvenFrame(sim.model.body_pos[body].copy(), yaw)


def place_oven(sim: SimHandle, rng: np.random.Generator, name: str, mouth_x: tuple[float, float],
               mouth_y: tuple[float, float], max_yaw: float, door_angle: float = 0.0) -> OvenFrame:
    """Stand the oven at a random mouth position and turn, with its door at ``door_angle``."""
    mouth = np.array([rng.uniform(*mouth_x), rng.uniform(*mouth_y), TABLE_TOP_Z])
    frame = OvenFrame(mouth, rng.uniform(-max_yaw, max_yaw))
    body = sim.body_id(name)
    sim.model.body_pos[body] = mouth
    sim.model.body_quat[body] = np.roll(frame.rotation.as_quat(), 1)
    sim.joint_qpos(f"{name}_door_hinge")[:] = door_angle
    sim.joint_qvel(f"{name}_door_hinge")[:] = 0.0
    return frame


def place_tray(sim: SimHandle, frame: OvenFrame, name: str, y: float) -> None:
    """Put the tray on the oven floor, its front edge 1.5 cm inside the mouth, ``y`` off the centre line."""
    sim.set_free_pose(f"{name}_joint", frame.to_world([TRAY_HALF[0] + 0.015, y, PLINTH]), frame.rotation.as_quat())


def door_angle(sim: SimHandle, name: str) -> float:
    return float(sim.joint_qpos(f"{name}_door_hinge")[0])
