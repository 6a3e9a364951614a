"""Clutter: look-alike objects that only the cameras see (the ``clutter`` perturbation).

Each piece is a small box, cylinder or sphere painted in a colour of the episode's goal objects, standing on the
table in the half of one arm or the other, clear of every object of the task. The pieces collide with nothing and
weigh nothing, so the physics and the expert are those of the scene without them: a policy that fails among them
fails on what it sees. Their class is ``clutter``, never a goal noun, so the arm-conditioned projection drops them
and a policy reading the whole scene does not.
"""

from __future__ import annotations

import mujoco
import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z

CLUTTER_PREFIX = "clutter_"
CLUTTER_CLASS = "clutter"
SHAPES = ("box", "cylinder", "sphere")
HALF_SIZE = 0.022  # a piece is 4.4 cm across: the size of a button, a ball or a block
REGION_X = (-0.18, 0.16)  # in front of the robots, inside both arms' reach
REGION_Y = (0.04, 0.32)  # one arm's half of the table, from the middle out (mirrored for the right arm)
CLEARANCE = 0.07  # from every body of the task (x, y): a piece never hides a goal, nor stands inside one
TRIES = 200


def clutter_name(i: int) -> str:
    return f"{CLUTTER_PREFIX}{i}"


def clutter_xml(count: int) -> str:
    """``count`` pieces, placed off the table until an episode places them (``place_clutter``)."""
    bodies = []
    for i in range(count):
        shape = SHAPES[i % len(SHAPES)]
        size = {"box": f"{HALF_SIZE} {HALF_SIZE} {HALF_SIZE}", "cylinder": f"{HALF_SIZE} {HALF_SIZE}",
                "sphere": f"{HALF_SIZE}"}[shape]
        # group 1: the cameras draw visual geoms only; contype/conaffinity 0: nothing touches it
        bodies.append(f'<body name="{clutter_name(i)}" pos="0 0 -1">'
                      f'<geom name="{clutter_name(i)}_geom" type="{shape}" size="{size}" contype="0" '
                      f'conaffinity="0" group="1" mass="0" rgba="0.5 0.5 0.5 1"/></body>')
    return "".join(bodies)


def place_clutter(model: mujoco.MjModel, data: mujoco.MjData, task_roots: list[int], colours: list[tuple],
                  rng: np.random.Generator) -> None:
    """Stand each piece on the table, alternately in the left and the right arm's half, ``CLEARANCE`` from every
    body under ``task_roots`` (a rope's every segment, a cloth's every vertex), each painted one of ``colours``
    in turn. Call after the task's objects are placed, then ``mj_forward``."""
    pieces = [b for b in range(1, model.nbody) if model.body(b).name.startswith(CLUTTER_PREFIX)]
    occupied = np.array([data.xpos[b, :2] for b in range(1, model.nbody)
                         if int(model.body_rootid[b]) in task_roots and b not in pieces]).reshape(-1, 2)
    placed: list[np.ndarray] = []
    for i, body in enumerate(pieces):
        side = 1.0 if i % 2 == 0 else -1.0
        for _ in range(TRIES):
            xy = np.array([rng.uniform(*REGION_X), side * rng.uniform(*REGION_Y)])
            others = np.vstack([occupied, *placed]) if placed else occupied
            if not len(others) or np.linalg.norm(others - xy, axis=1).min() >= CLEARANCE:
                break
        else:  # a crowded table: the piece stays off it rather than inside an object
            continue
        placed.append(xy[None])
        model.body_pos[body] = [xy[0], xy[1], TABLE_TOP_Z + HALF_SIZE]
        yaw = rng.uniform(-np.pi, np.pi)
        model.body_quat[body] = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
        geom = int(model.body_geomadr[body])
        model.geom_rgba[geom, :3] = colours[i % len(colours)]
