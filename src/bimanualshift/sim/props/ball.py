"""A large light ball (or, as an unseen shape, a cube of the same width)."""

from __future__ import annotations

from bimanualshift.sim.layout import TABLE_TOP_Z

BALL_RADIUS = 0.065


def ball_xml(name: str, radius: float = BALL_RADIUS, cube: bool = False) -> str:
    shape = f'type="box" size="{radius} {radius} {radius}"' if cube else f'type="sphere" size="{radius}"'
    inertia = 0.4 * 0.12 * radius**2
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z + radius}">
  <freejoint name="{name}_joint"/>
  <inertial pos="0 0 0" mass="0.12" diaginertia="{inertia} {inertia} {inertia}"/>
  <geom name="{name}_geom" {shape} rgba="1 0 0 1" group="1" friction="1.5 0.01 0.001" condim="4"/>
</body>"""
