"""Free-standing cubes and blocks."""

from __future__ import annotations

from bimanualshift.sim.layout import TABLE_TOP_Z

CUBE_HALF = 0.022


def cube_xml(name: str, sphere: bool = False) -> str:
    """A cube (or, as the unseen shape, a ball of the same width)."""
    h = CUBE_HALF
    shape = f'type="sphere" size="{h}"' if sphere else f'type="box" size="{h} {h} {h}"'
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z + h}">
  <freejoint name="{name}_joint"/>
  <inertial pos="0 0 0" mass="0.05" diaginertia="1.6e-5 1.6e-5 1.6e-5"/>
  <geom name="{name}_geom" {shape} rgba="1 0 0 1" group="1"
        friction="1.5 0.005 0.0001" solref="0.01 1"/>
</body>"""
