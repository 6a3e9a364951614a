"""A flower standing in a stand, for putting into a vase.

The flower is a thin stem under a square bloom. A hand takes it by the bloom's sides, fingers across two of its
faces, as it takes the threading block: a thin stem pinched on its own slipped 7-8 cm down through the closed
Robotiq when lifted, and the closing fingers pushed the hand 2 cm off it. The stand is fixed to the table (placed
per episode): four low walls around the stem's foot, which keep it upright until it is lifted out. Stem and
stand are smooth (friction 0.1), so the stem slides out of the stand and into the vase without catching."""

from __future__ import annotations

from bimanualshift.sim.layout import TABLE_TOP_Z

STEM_HALF_WIDTH = 0.006
STEM_LENGTH = 0.14
BLOOM_HALF = 0.022  # half the bloom's side; it is as tall as it is wide
BLOOM_CENTRE = STEM_LENGTH + BLOOM_HALF  # above the stem's foot (the flower's own origin)
STAND_HOLE_HALF = 0.012  # 6 mm of clearance around the stem: it leans 7 degrees at most in the stand
STAND_WALL = 0.012
STAND_HEIGHT = 0.05


def flower_xml(name: str = "flower") -> str:
    """A flower whose origin is its stem's foot: the stem upright along its z, the bloom on top."""
    smooth = 'friction="0.1 0.005 0.0001" condim="4" solref="0.01 1"'
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z}">
  <freejoint name="{name}_joint"/>
  <inertial pos="0 0 {0.6 * STEM_LENGTH:.4f}" mass="0.03" diaginertia="6e-5 6e-5 5e-6"/>
  <geom name="{name}_stem" type="box" size="{STEM_HALF_WIDTH} {STEM_HALF_WIDTH} {STEM_LENGTH / 2}"
        pos="0 0 {STEM_LENGTH / 2}" rgba="0.25 0.55 0.2 1" group="1" {smooth}/>
  <geom name="{name}_bloom" type="box" size="{BLOOM_HALF} {BLOOM_HALF} {BLOOM_HALF}" pos="0 0 {BLOOM_CENTRE}"
        rgba="0.9 0.3 0.5 1" group="1" friction="1.0 0.005 0.0001" condim="4"/>
</body>"""


def stand_xml(name: str = "stand") -> str:
    """Four walls around a square hole, fixed to the table; the episode places it (``model.body_pos``)."""
    h, w, z = STAND_HOLE_HALF, STAND_WALL, STAND_HEIGHT / 2
    outer = h + w
    walls = [(f"0 {h + w / 2} {z}", f"{outer} {w / 2} {z}"), (f"0 {-h - w / 2} {z}", f"{outer} {w / 2} {z}"),
             (f"{h + w / 2} 0 {z}", f"{w / 2} {h} {z}"), (f"{-h - w / 2} 0 {z}", f"{w / 2} {h} {z}")]
    geoms = "".join(f'\n  <geom name="{name}_wall{k}" type="box" pos="{pos}" size="{size}" rgba="0.35 0.3 0.25 1" '
                    'group="1" friction="0.1 0.005 0.0001" condim="4"/>' for k, (pos, size) in enumerate(walls))
    return f"""
<body name="{name}" pos="0 0 {TABLE_TOP_Z}">{geoms}
</body>"""
