"""A square rod and a block with a square hole through it, for threading the block onto the rod. Both are smooth
(friction 0.1): MuJoCo takes the larger coefficient of a pair, so the gripper's pads still hold them, while the
block slides along the rod instead of jamming on it."""

from __future__ import annotations

from bimanualshift.sim.layout import TABLE_TOP_Z

ROD_HALF_WIDTH = 0.015  # half the rod's square cross-section
ROD_HALF_LENGTH = 0.10
HOLE_HALF = 0.028  # half the hole's side: 1.3 cm of clearance around the rod on every side
BAR = 0.02  # the block's wall around the hole
BLOCK_HALF_THICKNESS = 0.0125  # half the block's depth along the hole
BLOCK_HALF = HOLE_HALF + BAR  # half the block's outer side
FLAT_ROD = (0.02, 0.01)  # the unseen shape's half width and half height


def rod_xml(name: str = "rod", mounted: bool = False, flat: bool = False) -> str:
    """The rod lies on the table along its y axis; ``mounted``, it is fixed in the air (placed per episode), on a
    post under its far (+y) end. ``flat`` (the unseen shape): a flat bar, 4 x 2 cm, that still fits the hole."""
    w, half = ROD_HALF_WIDTH, ROD_HALF_LENGTH
    across, up = FLAT_ROD if flat else (w, w)
    rod = (f'<geom name="{name}_geom" type="box" size="{across} {half} {up}" rgba="0.6 0.4 0.2 1" group="1"\n'
           '        friction="0.1 0.005 0.0001" condim="4" solref="0.01 1"/>')
    if mounted:
        post = (f'<geom name="{name}_post" type="box" pos="0 {half - w} -0.075" size="{w} {w} 0.075" '
                'rgba="0.3 0.3 0.3 1" group="1"/>')
        return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z + 0.15}">
  {rod}
  {post}
</body>"""
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z + up}">
  <freejoint name="{name}_joint"/>
  <inertial pos="0 0 0" mass="0.03" diaginertia="1e-4 5e-6 1e-4"/>
  {rod}
</body>"""


def block_xml(name: str = "block", wide: bool = False) -> str:
    """The block stands on the table with its hole along its y axis: four bars around a square hole. ``wide`` (the
    unseen shape): a flat frame, its side bars 1.25 times as wide and its top and bottom bars 0.75 times as tall."""
    h, b, t, o = HOLE_HALF, BAR, BLOCK_HALF_THICKNESS, BLOCK_HALF
    if wide:
        side, flat = 1.25 * BAR, 0.75 * BAR
        bars = [(f"0 0 {h + flat / 2}", f"{h + side} {t} {flat / 2}"),
                (f"0 0 {-h - flat / 2}", f"{h + side} {t} {flat / 2}"),
                (f"{h + side / 2} 0 0", f"{side / 2} {t} {h}"), (f"{-h - side / 2} 0 0", f"{side / 2} {t} {h}")]
        return _block(name, bars, h + flat)
    bars = [(f"0 0 {h + b / 2}", f"{o} {t} {b / 2}"), (f"0 0 {-h - b / 2}", f"{o} {t} {b / 2}"),
            (f"{h + b / 2} 0 0", f"{b / 2} {t} {h}"), (f"{-h - b / 2} 0 0", f"{b / 2} {t} {h}")]
    return _block(name, bars, o)


def _block(name: str, bars: list[tuple[str, str]], half_height: float) -> str:
    geoms = "".join(f'\n  <geom name="{name}_bar{k}" type="box" pos="{pos}" size="{size}" rgba="0.2 0.5 0.8 1" '
                    f'group="1" friction="0.1 0.005 0.0001" condim="4" solref="0.01 1"/>'
                    for k, (pos, size) in enumerate(bars))
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z + half_height}">
  <freejoint name="{name}_joint"/>
  <inertial pos="0 0 0" mass="0.03" diaginertia="3e-5 5e-5 3e-5"/>{geoms}
</body>"""
