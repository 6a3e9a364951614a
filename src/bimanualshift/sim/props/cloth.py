"""A quilt (MuJoCo's 2-D ``flexcomp`` cloth) lying flat on the table, with a grasp tab at each of its near corners.

A Robotiq pointing down cannot pinch a sheet lying flat: its fingertips reach the table but not under 6 mm of
cloth, and a strip hanging down a board's front has the board right behind it, where the far finger must go.
So the two near corners carry tabs, small rigid blocks tied to the corner vertex by a point constraint (an
equality ``connect``): a hand takes a tab by its sides, as it takes the threading block, and the corner follows.
The paper's real fingertips are compliant and scoop under the cloth instead.

The quilt is a grid of vertex bodies with free translation (``dof="full"``): an episode places it, and its tabs,
by setting those joints. The camera rig labels the flex's pixels as the invisible geom ``<quilt>_proxy``, whose
body names the quilt's instance (a flex has no geoms of its own)."""

from __future__ import annotations

import mujoco
import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.task import SimHandle

QUILT_COUNT = (7, 7)  # vertices along x (depth, away from the robots) and y (width)
QUILT_SPACING = 0.04  # 24 x 24 cm
QUILT_RADIUS = 0.003  # half the cloth's thickness (its collision radius)
TAB_HALF = (0.015, 0.015, 0.02)  # a tab is 3 x 3 cm, 4 cm tall
TABS = ("left", "right")  # the near corners with a tab (left: +y)


def corner_index(corner: str) -> tuple[int, int]:
    """(x index, y index) of a corner in the grid: near / far, left (+y) / right."""
    near, side = corner.split("_")
    return (0 if near == "near" else QUILT_COUNT[0] - 1), (QUILT_COUNT[1] - 1 if side == "left" else 0)


def _corner_local(corner: str) -> np.ndarray:
    """A corner's x, y in the quilt's own frame (its middle at the origin)."""
    return (np.array(corner_index(corner)) - (np.array(QUILT_COUNT) - 1) / 2) * QUILT_SPACING


def vertex_body_name(name: str, corner: str) -> str:
    i, j = corner_index(corner)
    return f"{name}_{i * QUILT_COUNT[1] + j}"


def quilt_xml(name: str = "quilt") -> str:
    """The quilt, laid flat centred on the world's origin (the episode places it), its two corner tabs and the
    constraints that tie each tab to its corner."""
    nx, ny = QUILT_COUNT
    # each tab compiled on its corner: a connect ties the two at the offset they have in the compiled scene
    at = {side: _corner_local(f"near_{side}") for side in TABS}
    tabs = "".join(f"""
<body name="{name}_tab_{side}" pos="{at[side][0]} {at[side][1]} {TABLE_TOP_Z + 2 * QUILT_RADIUS + TAB_HALF[2]}">
  <freejoint name="{name}_tab_{side}_joint"/>
  <inertial pos="0 0 0" mass="0.01" diaginertia="2e-6 2e-6 2e-6"/>
  <geom name="{name}_tab_{side}_geom" type="box" size="{TAB_HALF[0]} {TAB_HALF[1]} {TAB_HALF[2]}"
        rgba="0.3 0.3 0.35 1" group="1" friction="1.0 0.005 0.0001" condim="4"/>
</body>""" for side in TABS)
    ties = "".join(f'\n  <connect name="{name}_tie_{side}" body1="{name}_tab_{side}" '
                   f'body2="{vertex_body_name(name, f"near_{side}")}" anchor="0 0 {-(TAB_HALF[2] + QUILT_RADIUS)}"/>'
                   for side in TABS)
    return f"""
<flexcomp name="{name}" type="grid" count="{nx} {ny} 1" spacing="{QUILT_SPACING} {QUILT_SPACING} {QUILT_SPACING}"
          pos="0 0 {TABLE_TOP_Z + QUILT_RADIUS}" radius="{QUILT_RADIUS}" dim="2" mass="0.05" rgba="0.8 0.75 0.6 1">
  <contact condim="3" solref="0.01 1" selfcollide="none" friction="1.5 0.005 0.0001"/>
  <edge equality="true" damping="0.01"/>
  <elasticity young="3e4" poisson="0.2" thickness="{2 * QUILT_RADIUS}" damping="0.001"/>
</flexcomp>{tabs}
<body name="{name}_proxy" pos="0 0 -1">
  <geom name="{name}_proxy" type="sphere" size="0.001" group="3" contype="0" conaffinity="0" rgba="0 0 0 0"/>
</body>
<equality>{ties}
</equality>"""


def flex_id(sim: SimHandle, name: str = "quilt") -> int:
    return mujoco.mj_name2id(sim.model, mujoco.mjtObj.mjOBJ_FLEX, name)


def _vertex_range(sim: SimHandle, name: str) -> tuple[int, int]:
    flex = flex_id(sim, name)
    return int(sim.model.flex_vertadr[flex]), int(sim.model.flex_vertnum[flex])


def vertex_bodies(sim: SimHandle, name: str = "quilt") -> np.ndarray:
    """The quilt's vertex body ids, in the grid's order (x index major)."""
    start, count = _vertex_range(sim, name)
    return sim.model.flex_vertbodyid[start:start + count]


def vertices(sim: SimHandle, name: str = "quilt") -> np.ndarray:
    """(nx, ny, 3) world positions of the quilt's vertices."""
    start, count = _vertex_range(sim, name)
    return sim.data.flexvert_xpos[start:start + count].reshape(*QUILT_COUNT, 3).copy()


def corners(sim: SimHandle, name: str = "quilt") -> dict[str, np.ndarray]:
    """The four corners: near (towards the robots) and far, each left (+y) and right."""
    v = vertices(sim, name)
    return {c: v[corner_index(c)] for c in ("near_left", "near_right", "far_left", "far_right")}


def place_quilt(sim: SimHandle, centre: np.ndarray, yaw: float, name: str = "quilt") -> None:
    """The quilt flat on the table, its middle at ``centre`` (x, y) and turned by ``yaw``, each tab on its corner."""
    nx, ny = QUILT_COUNT
    c, s = np.cos(yaw), np.sin(yaw)
    turn = np.array([[c, -s], [s, c]])
    bodies = vertex_bodies(sim, name)
    for i in range(nx):
        for j in range(ny):
            local = (np.array([i, j]) - (np.array(QUILT_COUNT) - 1) / 2) * QUILT_SPACING
            body = bodies[i * ny + j]
            joint = sim.model.body_jntadr[body]
            qpos, dof = sim.model.jnt_qposadr[joint], sim.model.jnt_dofadr[joint]
            target = np.r_[np.asarray(centre) + turn @ local, TABLE_TOP_Z + QUILT_RADIUS]
            sim.data.qpos[qpos:qpos + 3] = target - sim.model.body_pos[body]
            sim.data.qvel[dof:dof + 3] = 0.0
    quat = np.array([0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2)])
    for side in TABS:
        corner = np.asarray(centre) + turn @ _corner_local(f"near_{side}")
        sim.set_free_pose(f"{name}_tab_{side}_joint", np.r_[corner, TABLE_TOP_Z + 2 * QUILT_RADIUS + TAB_HALF[2]],
                          quat)
