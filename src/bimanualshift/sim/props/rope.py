"""A deformable rope: MuJoCo's cable (a chain of capsules with the elasticity plugin) and target markers.

The cable's first body carries a free joint (``initial="free"``); the others hang from it through ball
joints, so an episode shapes the rope by setting the free pose and the ball joints' bends.
"""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.task import SimHandle, Task

CABLE_PLUGIN = "mujoco.elasticity.cable"
ROPE_RADIUS = 0.01
ROPE_SEGMENTS = 25
ROPE_LENGTH = 0.5
SEGMENT = ROPE_LENGTH / ROPE_SEGMENTS
REACH = ((-0.22, 0.28), (-0.36, 0.36))  # x, y every segment stays within
END_MAX_X = 0.14  # a gripper pointing down reaches the table surface only this far from the robots' bases


def rope_xml(prefix: str, radius: float = ROPE_RADIUS, segments: int = ROPE_SEGMENTS, length: float = ROPE_LENGTH,
             density: float = 300.0, damping: float = 0.02) -> str:
    """The cable laid straight along +x from the world's origin on the table (an episode shapes it)."""
    # Geoms stay in group 0 here so the compiler counts their mass; ``show_rope`` moves them to group 1.
    return f"""
<composite prefix="{prefix}_" type="cable" curve="s" count="{segments + 1} 1 1" size="{length}"
           offset="0 0 {TABLE_TOP_Z + radius}" initial="free">
  <plugin plugin="{CABLE_PLUGIN}">
    <config key="twist" value="2e4"/>
    <config key="bend" value="1e4"/>
    <config key="vmax" value="0"/>
  </plugin>
  <joint kind="main" damping="{damping}"/>
  <geom type="capsule" size="{radius}" rgba="0.8 0.2 0.1 1" condim="3" density="{density}"
        friction="1.2 0.005 0.0001"/>
</composite>"""


def rope_bodies(prefix: str, segments: int = ROPE_SEGMENTS) -> list[str]:
    return [f"{prefix}_B_first", *(f"{prefix}_B_{i}" for i in range(1, segments - 1)), f"{prefix}_B_last"]


def show_rope(model: mujoco.MjModel, prefix: str, segments: int = ROPE_SEGMENTS) -> None:
    for name in rope_bodies(prefix, segments):
        body = model.body(name).id
        for g in range(model.body_geomadr[body], model.body_geomadr[body] + model.body_geomnum[body]):
            model.geom_group[g] = 1


def shape_rope(sim: SimHandle, prefix: str, start: np.ndarray, heading: float, bends: np.ndarray,
               radius: float = ROPE_RADIUS) -> None:
    """Lay the rope flat from ``start`` (xy) at ``heading`` (rad), turning by ``bends[i]`` at joint i (a rope of
    ``len(bends) + 1`` segments)."""
    sim.set_free_pose(f"{prefix}_J_first", np.r_[start, TABLE_TOP_Z + radius],
                      Rotation.from_euler("z", heading).as_quat())
    for i, bend in enumerate(bends, start=1):
        joint = f"{prefix}_J_{i}" if i < len(bends) else f"{prefix}_J_last"
        sim.joint_qpos(joint)[:] = np.roll(Rotation.from_euler("z", bend).as_quat(), 1)
        sim.joint_qvel(joint)[:] = 0.0


def flat_chain(heading: float, bends: np.ndarray, segment: float = SEGMENT) -> np.ndarray:
    """xy of every segment's start (and the rope's far end) for a flat rope starting at the origin."""
    angles = heading + np.r_[0.0, np.cumsum(bends)]
    steps = segment * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    return np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)])


def rope_end_grasp(sim: SimHandle, prefix: str, head: bool) -> tuple[np.ndarray, float]:
    """Where to pinch the rope near one end (the end segment's middle) and the rope's direction there."""
    body = sim.body_id(rope_bodies(prefix)[0 if head else -1])
    axis = sim.data.xmat[body].reshape(3, 3)[:, 0]
    point = sim.data.xpos[body] + axis * SEGMENT / 2
    return point, float(np.arctan2(axis[1], axis[0]))


def rope_ends(sim: SimHandle, prefix: str, segments: int = ROPE_SEGMENTS, segment: float = SEGMENT
              ) -> tuple[np.ndarray, np.ndarray]:
    first = sim.body_id(rope_bodies(prefix, segments)[0])
    last = sim.body_id(rope_bodies(prefix, segments)[-1])
    tail = sim.data.xpos[last] + sim.data.xmat[last].reshape(3, 3)[:, 0] * segment
    return sim.data.xpos[first].copy(), tail


def crumpled_rope(rng: np.random.Generator, centre_y: tuple[float, float] = (-0.05, 0.05),
                  reach_y: tuple[float, float] = REACH[1]) -> tuple[np.ndarray, float, np.ndarray, np.ndarray]:
    """A random smooth bend profile (head xy, heading, bends, tail xy) that keeps the rope on the table, within
    ``reach_y`` and untangled, its centre's y in ``centre_y``."""
    s = (np.arange(1, ROPE_SEGMENTS) + 0.5) * SEGMENT
    for _ in range(500):
        a, b, c = rng.uniform(-6, 6), rng.uniform(3, 9), rng.uniform(0, 2 * np.pi)
        bends = (a + b * np.sin(2 * np.pi * s / (ROPE_SEGMENTS * SEGMENT) + c)) * SEGMENT
        heading = -np.pi / 2 + rng.uniform(-np.pi / 4, np.pi / 4)  # head on the left, pointing right
        chain = flat_chain(heading, bends)
        centre = np.array([rng.uniform(-0.05, 0.10), rng.uniform(*centre_y)])
        chain += centre - chain.mean(axis=0)
        span = np.linalg.norm(chain[-1] - chain[0])
        far = np.linalg.norm(chain[:, None] - chain[None], axis=-1)[np.triu_indices(len(chain), k=3)]
        inside = np.all((chain >= [REACH[0][0], reach_y[0]]) & (chain <= [REACH[0][1], reach_y[1]]))
        reachable = max(chain[0, 0], chain[-1, 0]) < END_MAX_X
        if span < 0.38 and far.min() > 0.028 and inside and reachable and chain[0, 1] > chain[-1, 1] + 0.08:
            return chain[0], heading, bends, chain[-1]
    raise RuntimeError("could not sample a rope shape")


class RopeTask(Task):
    """The hooks both rope tasks share: a cable named ``rope`` (MuJoCo's cable plugin), made visible after
    compiling, seen as one instance, and coloured in one colour."""

    plugins = (CABLE_PLUGIN,)

    def after_compile(self, model: mujoco.MjModel) -> None:
        show_rope(model, "rope")

    def instance_name(self, root_body: str) -> str:
        return "rope" if root_body == rope_bodies("rope")[0] else root_body

    def crumple_rope(self, sim: SimHandle, rng: np.random.Generator, **placement: tuple[float, float]
                     ) -> tuple[np.ndarray, np.ndarray]:
        """Lay the rope out crumpled at random (``crumpled_rope``, ``placement`` its ranges); where its head
        and its tail start."""
        start, heading, bends, tail = crumpled_rope(rng, **placement)
        shape_rope(sim, "rope", start, heading, bends)
        return start, tail

    def colour_rope(self, sim: SimHandle, colour: str) -> None:
        for body in rope_bodies("rope"):
            sim.model.geom_rgba[sim.model.body_geomadr[sim.body_id(body)], :3] = self.palette[colour]
