"""Cups with a handle, and the small balls that stand in for water, for pouring from one cup into another.

A cup is a ring of wall segments on a floor, with a flat handle sticking out of its -y side: a hand steadying a cup
on the table grips the handle, fingers across it. A hand that lifts a cup pinches its rim instead, one finger inside
the wall: held by the handle, the cup's weight, 9 cm out, turned it 55 degrees about the fingers' axis. The balls
are frictionless (``condim="1"``, and ``priority`` so that their contacts with the walls stay so), as water is, and
cheap: with friction, 40 of them made a physics step cost 25-60 ms; without, 1.7 ms."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.task import SimHandle

CUP_RADIUS = 0.05  # inner: 40 balls fill it 3 cm deep, so carrying it sloshes none out
CUP_HEIGHT = 0.11
CUP_WALL = 0.005
CUP_FLOOR = 0.006
SEGMENTS = 16
CUP_HANDLE = (0.008, 0.045, 0.03)  # half sizes (x, y, z): it sticks out 9 cm from the wall, its top 1 cm below the rim
# Torsional friction of the walls (condim 4): a pinched rim's pads have area, so the cup does not spin about the
# fingers' axis when the hand accelerates sideways (without it, the carry swung the cup 37 degrees).
WALL_TORSION = 0.02
BALL_RADIUS = 0.007
BALLS = 40


def cup_xml(name: str, mounted: bool = False, rgba: str = "0.8 0.8 0.8 1") -> str:
    """A cup standing on the table (``mounted``: fixed to it, placed per episode)."""
    half_h = (CUP_HEIGHT - CUP_FLOOR) / 2
    ring = CUP_RADIUS + CUP_WALL / 2
    half_len = ring * np.tan(np.pi / SEGMENTS) + CUP_WALL / 2
    style = f'group="1" rgba="{rgba}" condim="4" friction="0.8 {WALL_TORSION} 0.0001"'
    geoms = [f'<geom name="{name}_floor" type="cylinder" size="{CUP_RADIUS + CUP_WALL} {CUP_FLOOR / 2}" '
             f'pos="0 0 {CUP_FLOOR / 2}" {style}/>']
    for i in range(SEGMENTS):
        a = 2 * np.pi * i / SEGMENTS
        geoms.append(f'<geom name="{name}_wall{i}" type="box" size="{CUP_WALL / 2} {half_len:.4f} {half_h}" '
                     f'pos="{ring * np.cos(a):.4f} {ring * np.sin(a):.4f} {CUP_FLOOR + half_h}" euler="0 0 {a:.4f}" '
                     f'{style}/>')
    hx, hy, hz = CUP_HANDLE
    geoms.append(f'<geom name="{name}_handle" type="box" size="{hx} {hy} {hz}" '
                 f'pos="0 {-(CUP_RADIUS + CUP_WALL + hy)} {CUP_HEIGHT - 0.01 - hz}" group="1" rgba="0.2 0.2 0.22 1" '
                 'friction="1.5 0.005 0.0001"/>')
    joint = "" if mounted else (f'<freejoint name="{name}_joint"/>\n  <inertial pos="0 0 {CUP_HEIGHT / 3}" '
                                'mass="0.1" diaginertia="2e-4 2e-4 1e-4"/>')
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z}">
  {joint}
  {"".join(geoms)}
</body>"""


def water_xml(n: int = BALLS) -> str:
    """``n`` balls, each a body of its own (``water_<i>``), placed in a cup per episode."""
    return "".join(f"""
<body name="water_{i}" pos="{2 + 0.02 * i} 0 {TABLE_TOP_Z}">
  <freejoint name="water_{i}_joint"/>
  <inertial pos="0 0 0" mass="0.002" diaginertia="4e-8 4e-8 4e-8"/>
  <geom name="water_{i}_geom" type="sphere" size="{BALL_RADIUS}" group="1" rgba="0.2 0.45 0.9 1"
        condim="1" priority="1" solref="0.01 1"/>
</body>""" for i in range(n))


def fill_cup(sim: SimHandle, centre: np.ndarray, rng: np.random.Generator, n: int = BALLS) -> None:
    """The balls stacked in the cup at ``centre`` (x, y), in layers on a jittered grid."""
    spacing = 2 * BALL_RADIUS + 0.001
    grid = [(x, y) for x in np.arange(-3, 4) * spacing for y in np.arange(-3, 4) * spacing
            if np.hypot(x, y) < CUP_RADIUS - BALL_RADIUS]
    for i in range(n):
        x, y = grid[i % len(grid)]
        layer = i // len(grid)
        jitter = rng.uniform(-0.001, 0.001, size=2)
        sim.set_free_pose(f"water_{i}_joint",
                          np.array([centre[0] + x + jitter[0], centre[1] + y + jitter[1],
                                    TABLE_TOP_Z + CUP_FLOOR + BALL_RADIUS + 0.001 + layer * spacing]))


def in_cup(sim: SimHandle, cup: str, point: np.ndarray) -> bool:
    """Whether ``point`` lies inside the cup's walls and below its rim."""
    body = sim.body_id(cup)
    local = sim.data.xmat[body].reshape(3, 3).T @ (point - sim.data.xpos[body])
    return bool(np.hypot(local[0], local[1]) < CUP_RADIUS and -0.01 < local[2] < CUP_HEIGHT)


def water_in(sim: SimHandle, cup: str, n: int = BALLS) -> float:
    """The share of the balls inside ``cup``."""
    return float(np.mean([in_cup(sim, cup, sim.body_pos(f"water_{i}")) for i in range(n)]))
