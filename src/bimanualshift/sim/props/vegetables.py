"""Toy vegetables and open bins for the sorting task: simple solids a parallel gripper closes across."""

from __future__ import annotations

from bimanualshift.sim.layout import TABLE_TOP_Z

# category -> (MuJoCo geom type, size, half-height when lying on the table); elongated ones lie along their x axis
VEGETABLES: dict[str, tuple[str, str, float]] = {
    # thick enough that the Robotiq's pads, which start 1 cm above the table, close below the middle
    "carrot": ("capsule", "0.022 0.04", 0.022),  # radius, half-length of the cylinder part
    "cucumber": ("capsule", "0.025 0.035", 0.025),
    "tomato": ("sphere", "0.026", 0.026),
    "potato": ("ellipsoid", "0.035 0.026 0.022", 0.022),
    "pepper": ("cylinder", "0.028 0.03", 0.028),  # lying on its side: the axis along x
}
BIN_INNER_HALF = 0.065  # the bin's inner half-width (metres)
BIN_WALL = 0.008  # wall half-thickness
BIN_HEIGHT = 0.045  # wall height above its floor
BIN_FLOOR = 0.005  # floor half-thickness


def vegetable_xml(category: str) -> str:
    kind, size, half = VEGETABLES[category]
    # a cylinder's axis is its z: turn it (and the capsules) to lie along x
    quat = ' quat="0.7071068 0 0.7071068 0"' if kind in ("capsule", "cylinder") else ""
    return f"""
<body name="{category}" pos="0 0 {TABLE_TOP_Z + half}">
  <freejoint name="{category}_joint"/>
  <inertial pos="0 0 0" mass="0.06" diaginertia="2e-5 2e-5 2e-5"/>
  <geom name="{category}_geom" type="{kind}" size="{size}"{quat} rgba="0.8 0.4 0.1 1" group="1" mass="0.06"
        friction="1.5 0.005 0.0001" condim="4" solref="0.01 1"/>
</body>"""


def bin_xml(name: str) -> str:
    """An open box standing on the table: a floor and four walls (a body of its own, placed per episode)."""
    i, w, h, f = BIN_INNER_HALF, BIN_WALL, BIN_HEIGHT / 2, BIN_FLOOR
    outer = i + w
    walls = [(f"{outer} 0", f"{w} {outer} {h}"), (f"-{outer} 0", f"{w} {outer} {h}"),
             (f"0 {outer}", f"{i} {w} {h}"), (f"0 -{outer}", f"{i} {w} {h}")]
    geoms = "".join(f'\n  <geom name="{name}_wall{k}" type="box" pos="{xy} {2 * f + h}" size="{size}" '
                    f'rgba="0.45 0.45 0.5 1" group="1"/>' for k, (xy, size) in enumerate(walls))
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z}">
  <geom name="{name}_floor" type="box" pos="0 0 {f}" size="{outer} {outer} {f}" rgba="0.45 0.45 0.5 1"
        group="1"/>{geoms}
</body>"""
