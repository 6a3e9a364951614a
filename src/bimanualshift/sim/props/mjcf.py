"""MJCF text shared by the props."""

from __future__ import annotations


def free_body(name: str, z: float, geoms: list[str], mass: float, inertia: tuple[float, float, float],
              com_z: float) -> str:
    """A body named ``name`` on a free joint ``<name>_joint``, starting at height ``z``, made of ``geoms``."""
    return f"""
<body name="{name}" pos="0 0 {z}">
  <freejoint name="{name}_joint"/>
  <inertial pos="0 0 {com_z}" mass="{mass}" diaginertia="{inertia[0]} {inertia[1]} {inertia[2]}"/>
  {"".join(geoms)}
</body>"""
