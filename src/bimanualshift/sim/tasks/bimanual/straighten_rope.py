"""Straighten a rope: a crumpled rope; each arm takes one end and pulls it into its target region."""

from __future__ import annotations

import mujoco
import numpy as np

from bimanualshift.sim.props.rope import (
    CABLE_PLUGIN,
    ROPE_SEGMENTS,
    SEGMENT,
    flat_chain,
    marker_xml,
    rope_bodies,
    rope_end_grasp,
    rope_ends,
    rope_xml,
    shape_rope,
    show_rope,
)
from bimanualshift.sim.scene import TABLE_TOP_Z
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, Task, down_quat, register_task

TARGET_RADIUS = 0.06
TARGETS = {"head_target": (0.05, 0.23), "tail_target": (0.05, -0.23)}
PHRASINGS = (
    "straighten the rope",
    "pull the rope straight",
    "straighten out the rope",
    "pull both ends of the rope apart",
    "lay the rope out straight",
    "stretch the rope between the two targets",
)
REACH = ((-0.22, 0.28), (-0.36, 0.36))
GRASP_Z = TABLE_TOP_Z + 0.012  # gripper site over a rope lying on the table: pads around it, tips clear
CARRY_Z = TABLE_TOP_Z + 0.06
END_MAX_X = 0.14  # a gripper pointing down reaches the table surface only this far from the robots' bases


def crumpled_rope(rng: np.random.Generator) -> tuple[np.ndarray, float, np.ndarray]:
    """A random smooth bend profile (start xy, heading, bends) that keeps the rope on the table and untangled."""
    s = (np.arange(1, ROPE_SEGMENTS) + 0.5) * SEGMENT
    for _ in range(500):
        a, b, c = rng.uniform(-6, 6), rng.uniform(3, 9), rng.uniform(0, 2 * np.pi)
        bends = (a + b * np.sin(2 * np.pi * s / (ROPE_SEGMENTS * SEGMENT) + c)) * SEGMENT
        heading = -np.pi / 2 + rng.uniform(-np.pi / 4, np.pi / 4)  # head on the left, pointing right
        chain = flat_chain(heading, bends)
        centre = np.array([rng.uniform(-0.05, 0.10), rng.uniform(-0.05, 0.05)])
        chain += centre - chain.mean(axis=0)
        span = np.linalg.norm(chain[-1] - chain[0])
        far = np.linalg.norm(chain[:, None] - chain[None], axis=-1)[np.triu_indices(len(chain), k=3)]
        inside = np.all((chain >= [REACH[0][0], REACH[1][0]]) & (chain <= [REACH[0][1], REACH[1][1]]))
        reachable = max(chain[0, 0], chain[-1, 0]) < END_MAX_X
        if span < 0.38 and far.min() > 0.028 and inside and reachable and chain[0, 1] > chain[-1, 1] + 0.08:
            return chain[0], heading, bends
    raise RuntimeError("could not sample a rope shape")


@register_task("straighten_rope")
class StraightenRope(Task):
    bimanual = True
    plugins = (CABLE_PLUGIN,)

    def scene_xml(self) -> str:
        return rope_xml("rope") + "".join(marker_xml(name, TARGET_RADIUS) for name in TARGETS)

    def after_compile(self, model: mujoco.MjModel) -> None:
        show_rope(model, "rope")

    def instance_name(self, root_body: str) -> str:
        return "rope" if root_body == rope_bodies("rope")[0] else root_body

    def instance_class(self, instance: str) -> str:
        return "target" if instance.endswith("_target") else instance

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        for name, xy in TARGETS.items():
            sim.model.body_pos[sim.body_id(name)] = (*xy, TABLE_TOP_Z)
        start, heading, bends = crumpled_rope(rng)
        shape_rope(sim, "rope", start, heading, bends)
        colour = self.pick_colours(rng, 1)[0]
        for body in rope_bodies("rope"):
            b = sim.body_id(body)
            sim.model.geom_rgba[sim.model.body_geomadr[b], :3] = self.palette[colour]
        self.episode = {"colour": colour, "phrasing": int(rng.integers(len(PHRASINGS)))}

    def instruction(self) -> str:
        return PHRASINGS[self.episode["phrasing"]]

    def goal_nouns(self) -> list[str]:
        return ["rope"]

    def evaluate_success(self, sim: SimHandle) -> bool:
        head, tail = rope_ends(sim, "rope")
        near = [np.linalg.norm(end[:2] - sim.body_pos(target)[:2]) < TARGET_RADIUS
                for end, target in ((head, "head_target"), (tail, "tail_target"))]
        return bool(all(near))

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        ends = {"head": rope_end_grasp(sim, "rope", head=True), "tail": rope_end_grasp(sim, "rope", head=False)}
        targets = {"head": sim.body_pos("head_target"), "tail": sim.body_pos("tail_target")}
        # Each arm takes the end lying on its side (the layout may be mirrored).
        head_arm = "left" if ends["head"][0][1] > ends["tail"][0][1] else "right"
        role = {head_arm: "head", ("right" if head_arm == "left" else "left"): "tail"}
        frames: list[Keyframe] = []

        def add(where: str, z: float, gripper: float) -> None:
            frame = {}
            for arm, end in role.items():
                point, direction = ends[end]
                xy = point[:2] if where == "grasp" else targets[end][:2] + (point[:2] - rope_ends_xy[end])
                frame[arm] = ArmAction(np.r_[xy, z], down_quat(direction), gripper, 1.0)
            frames.append(frame)

        head, tail = rope_ends(sim, "rope")
        rope_ends_xy = {"head": head[:2], "tail": tail[:2]}
        add("grasp", GRASP_Z + 0.08, 1.0)
        add("grasp", GRASP_Z, 1.0)
        add("grasp", GRASP_Z, 0.0)
        add("grasp", CARRY_Z, 0.0)
        add("target", CARRY_Z, 0.0)
        add("target", GRASP_Z + 0.01, 0.0)
        add("target", GRASP_Z + 0.01, 1.0)
        add("target", CARRY_Z, 1.0)
        return frames
