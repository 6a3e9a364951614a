"""Target markers painted on the table."""

from __future__ import annotations

from bimanualshift.sim.layout import TABLE_TOP_Z


def marker_xml(name: str, radius: float) -> str:
    """A flat disc painted on the table: seen by cameras, touched by nothing."""
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z}">
  <geom name="{name}_geom" type="cylinder" size="{radius} 0.0008" pos="0 0 0.0008" contype="0" conaffinity="0"
        group="1" rgba="0.2 0.8 0.2 1"/>
</body>"""
