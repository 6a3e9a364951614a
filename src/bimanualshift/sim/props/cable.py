"""A cable with a plug at each end, and the clips it is routed through.

The cable is MuJoCo's (the elasticity plugin's chain of capsules, ``props.rope``), thinner than the rope. A Robotiq
140 pointing down cannot pinch a 1.2 cm cable lying on the table (its fingertips stop on the table beside it), so
each end carries a plug: a small block welded to the end segment, which a hand takes by its sides as it takes the
quilt's tabs. A clip is two posts standing on the table with a gap between them that the cable fits into from
above: a routed cable lies down the gap."""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.rope import rope_bodies, rope_xml, shape_rope, show_rope
from bimanualshift.sim.task import SimHandle

CABLE_RADIUS = 0.006
CABLE_SEGMENTS = 22
CABLE_LENGTH = 0.44
CABLE_SEGMENT = CABLE_LENGTH / CABLE_SEGMENTS
CABLE_DAMPING = 0.2  # at its joints, ten times the rope's: a cable carried high stops swinging before it is laid
PLUG_HALF = (0.015, 0.015, 0.02)  # a plug is 3 x 3 cm, 4 cm tall, its foot on the table
PLUG_CENTRES = CABLE_LENGTH + 2 * PLUG_HALF[0]  # between the two plugs' centres along a straight cable
ENDS = ("head", "tail")  # the cable's first and last segments
POST_HALF = (0.006, 0.015, 0.02)  # a clip's post: 1.2 cm across the cable, 3 cm along it, 4 cm tall
CLIP_GAP = 0.032  # between a clip's two posts (inner faces): 2.6 times the cable's width


def plug_offset(end: str) -> np.ndarray:
    """The plug's centre in its end segment's frame (x along the cable, from the segment's start)."""
    along = -PLUG_HALF[0] if end == "head" else CABLE_SEGMENT + PLUG_HALF[0]
    return np.array([along, 0.0, PLUG_HALF[2] - CABLE_RADIUS])


def plug_turn(end: str) -> Rotation:
    """The plug's frame in its end segment's: each plug's x axis points into the cable (the tail's is turned half
    a turn), so a plug's yaw says which way the cable leaves it, whichever end it is."""
    return Rotation.identity() if end == "head" else Rotation.from_euler("z", np.pi)


def end_body(end: str, name: str = "cable") -> str:
    bodies = rope_bodies(name, CABLE_SEGMENTS)
    return bodies[0] if end == "head" else bodies[-1]


def _wxyz(turn: Rotation) -> str:
    return " ".join(f"{q:.6f}" for q in np.roll(turn.as_quat(), 1))


def _compiled_plug(end: str) -> np.ndarray:
    """Where the plug at ``end`` is compiled: on its segment of the cable laid straight along +x from the origin."""
    start = np.zeros(3) if end == "head" else np.array([CABLE_LENGTH - CABLE_SEGMENT, 0.0, 0.0])
    return start + plug_offset(end) + [0.0, 0.0, TABLE_TOP_Z + CABLE_RADIUS]


def cable_xml(name: str = "cable", anchored: str = "") -> str:
    """The cable laid straight along +x from the origin (an episode shapes it), a plug welded to each end. With
    ``anchored`` (an end), that end's plug is also welded to a mocap body, ``<name>_anchor``: a clamp the episode
    places (``anchor_plug``), which holds it still."""
    plugs = welds = ""
    for end in ENDS:  # compiled where it sits on its segment: the weld keeps that relative pose
        x, y, z = _compiled_plug(end)
        plugs += f"""
<body name="{name}_plug_{end}" pos="{x} {y} {z}" quat="{_wxyz(plug_turn(end))}">
  <freejoint name="{name}_plug_{end}_joint"/>
  <inertial pos="0 0 0" mass="0.02" diaginertia="4e-6 4e-6 4e-6"/>
  <geom name="{name}_plug_{end}_geom" type="box" size="{PLUG_HALF[0]} {PLUG_HALF[1]} {PLUG_HALF[2]}"
        rgba="0.15 0.15 0.18 1" group="1" friction="1.0 0.005 0.0001" condim="4"/>
</body>"""
        welds += f'\n  <weld name="{name}_weld_{end}" body1="{name}_plug_{end}" body2="{end_body(end, name)}"/>'
    if anchored:
        x, y, z = _compiled_plug(anchored)
        plugs += f'\n<body name="{name}_anchor" mocap="true" pos="{x} {y} {z}" quat="{_wxyz(plug_turn(anchored))}"/>'
        welds += f'\n  <weld name="{name}_clamp" body1="{name}_anchor" body2="{name}_plug_{anchored}"/>'
    cable = rope_xml(name, radius=CABLE_RADIUS, segments=CABLE_SEGMENTS, length=CABLE_LENGTH, density=1000.0,
                      damping=CABLE_DAMPING)
    return f"{cable}{plugs}\n<equality>{welds}\n</equality>"


def clip_xml(name: str) -> str:
    """A clip: two posts either side of its gap (along x), fixed on the table; the episode places it."""
    off = CLIP_GAP / 2 + POST_HALF[0]
    posts = "".join(f"""
  <geom name="{name}_post_{i}" type="box" pos="{x} 0 {POST_HALF[2]}" size="{POST_HALF[0]} {POST_HALF[1]} {POST_HALF[2]}"
        rgba="0.85 0.85 0.8 1" group="1" friction="0.6 0.005 0.0001"/>""" for i, x in enumerate((-off, off)))
    return f'\n<body name="{name}" pos="0 0 {TABLE_TOP_Z}">{posts}\n</body>'


def show_cable(model: mujoco.MjModel, name: str = "cable") -> None:
    show_rope(model, name, CABLE_SEGMENTS)


def lay_cable(sim: SimHandle, start: np.ndarray, heading: float, bends: np.ndarray, name: str = "cable") -> None:
    """The cable flat on the table from ``start`` (xy) at ``heading``, bent by ``bends`` (one per joint), each
    plug where its weld holds it."""
    shape_rope(sim, name, start, heading, bends, radius=CABLE_RADIUS)
    mujoco.mj_kinematics(sim.model, sim.data)
    for end in ENDS:
        body = sim.body_id(end_body(end, name))
        turn = Rotation.from_matrix(sim.data.xmat[body].reshape(3, 3))
        sim.set_free_pose(f"{name}_plug_{end}_joint", sim.data.xpos[body] + turn.apply(plug_offset(end)),
                          (turn * plug_turn(end)).as_quat())
    mujoco.mj_kinematics(sim.model, sim.data)


def anchor_plug(sim: SimHandle, end: str, name: str = "cable") -> None:
    """Clamp the plug at ``end`` where it lies now (the cable's mocap anchor moved onto it)."""
    anchor = sim.model.body_mocapid[sim.body_id(f"{name}_anchor")]
    plug = sim.body_id(f"{name}_plug_{end}")
    sim.data.mocap_pos[anchor] = sim.data.xpos[plug]
    sim.data.mocap_quat[anchor] = sim.data.xquat[plug]


def cable_points(sim: SimHandle, name: str = "cable") -> np.ndarray:
    """(segments, 3) the middle of every segment of the cable."""
    points = []
    for body in rope_bodies(name, CABLE_SEGMENTS):
        b = sim.body_id(body)
        points.append(sim.data.xpos[b] + sim.data.xmat[b].reshape(3, 3)[:, 0] * CABLE_SEGMENT / 2)
    return np.array(points)


def through_clip(sim: SimHandle, clip: str, name: str = "cable") -> bool:
    """Whether the cable lies down the clip's gap: some segment's middle between the posts, along their length,
    below their tops."""
    frame = sim.data.xmat[sim.body_id(clip)].reshape(3, 3)
    local = (cable_points(sim, name) - sim.body_pos(clip)) @ frame
    inside = (np.abs(local[:, 0]) < CLIP_GAP / 2) & (np.abs(local[:, 1]) < POST_HALF[1]) & (
        local[:, 2] < 2 * POST_HALF[2])
    return bool(inside.any())
