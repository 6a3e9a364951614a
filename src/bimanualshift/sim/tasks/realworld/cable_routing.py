"""Cable routing (the paper's real-world Precision tier, 5 keyframes): a cable lies on the table in front of two
clips. Each arm takes the plug at its end of the cable; together they lift the cable clear of the clips, carry it
over their line and lay it down into both clips' gaps, holding it there. Success: the cable down both gaps, each
plug beyond the clip on its own side. The gaps are 2.6 cable widths wide, so the cable's line must fall within
1 cm of the clips' line: both hands must put their plugs on it."""

from __future__ import annotations

import mujoco
import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z, arms_by_side
from bimanualshift.sim.props.cable import (
    CABLE_SEGMENT,
    CABLE_SEGMENTS,
    ENDS,
    PLUG_CENTRES,
    PLUG_HALF,
    cable_xml,
    clip_xml,
    lay_cable,
    show_cable,
    through_clip,
)
from bimanualshift.sim.props.rope import CABLE_PLUGIN, rope_bodies
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, Task, register_task
from bimanualshift.sim.tasks.realworld.block_threading import grasp_from_above, hand_down

CLIP_X = (0.02, 0.07)  # the clips' line (x) across the table
CLIP_Y = (0.07, 0.10)  # |y| of each clip
CABLE_BEFORE = (0.07, 0.10)  # the cable starts this far before the clips' line (towards the robots)
HEAD_Y = (0.20, 0.23)  # the cable's head (its +y end)
TURN = np.deg2rad(3.0)  # the cable's direction wanders by up to twice this from its start's, smoothly
LIFT = 0.18  # a plug's centre this high above the table while the cable is carried: it hangs clear of the clips
SPAN = PLUG_CENTRES - 0.01  # the plugs carried this far apart: 1 cm short of straight (more slack arches it)
LAID = 0.005  # a plug lowered until its foot is this high above the table


def route_keyframes(sim: SimHandle, end: str, over: np.ndarray) -> list[ArmAction]:
    """One arm's five keyframes for the plug at ``end``: above it, closed on it, lifted straight up, carried
    over ``over`` (x, y) and lowered onto the table there, still held (a plug let go of tips over on the
    cable's pull and drags its end out of the clip)."""
    plug = sim.body_pos(f"cable_plug_{end}")
    quat = hand_down(np.pi / 2)  # fingers on the plug's faces across the route: the cable leaves another face
    lifted = np.r_[plug[:2], TABLE_TOP_Z + LIFT]
    carried = np.r_[over, TABLE_TOP_Z + LIFT]
    laid = np.r_[over, TABLE_TOP_Z + PLUG_HALF[2] + LAID]
    return [*grasp_from_above(plug, quat), ArmAction(lifted, quat, 0.0, 1.0), ArmAction(carried, quat, 0.0, 1.0),
            ArmAction(laid, quat, 0.0, 0.0)]


def bent_cable(rng: np.random.Generator) -> np.ndarray:
    """A smooth gentle bend profile (one bend per joint) that leaves the cable nearly straight: its direction
    wanders as a sine, so it never drifts far to one side."""
    s = np.linspace(0.0, 1.0, CABLE_SEGMENTS)
    direction = TURN * np.sin(2 * np.pi * s * rng.uniform(0.5, 1.5) + rng.uniform(0, 2 * np.pi))
    return np.diff(direction)


class CableTask(Task):
    """What the cable tasks share: the robot, the plugin, the cable's looks and names."""

    robot = "ur5e"
    plugins = (CABLE_PLUGIN,)

    def after_compile(self, model: mujoco.MjModel) -> None:
        show_cable(model)

    def instance_name(self, root_body: str) -> str:
        return "cable" if root_body == rope_bodies("cable", CABLE_SEGMENTS)[0] else root_body

    def instance_class(self, instance: str) -> str:
        if instance.startswith("cable"):
            return "cable"  # its plugs included
        return "clip" if instance.startswith("clip") else super().instance_class(instance)

    def goal_nouns(self) -> list[str]:
        return ["cable", "clip"]

    def lay(self, sim: SimHandle, rng: np.random.Generator, head: np.ndarray, heading: float = -np.pi / 2) -> None:
        """The cable from ``head`` (xy) at ``heading`` (by default towards -y), gently bent, in one colour of the
        palette."""
        lay_cable(sim, head, heading, bent_cable(rng))
        colour = self.pick_colours(rng, 1)[0]
        for body in rope_bodies("cable", CABLE_SEGMENTS):
            sim.model.geom_rgba[sim.model.body_geomadr[sim.body_id(body)], :3] = self.palette[colour]
        self.episode = {"colour": colour}

    def place_clip(self, sim: SimHandle, name: str, xy: np.ndarray) -> None:
        sim.model.body_pos[sim.body_id(name)] = (*xy, TABLE_TOP_Z)


@register_task("cable_routing")
class CableRouting(CableTask):
    bimanual = True
    tier = "Precision"
    paper_keyframes = 5

    def scene_xml(self) -> str:
        return cable_xml() + clip_xml("clip_left") + clip_xml("clip_right")

    def instruction(self) -> str:
        return "route the cable through the clips"

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        x = rng.uniform(*CLIP_X)
        self.place_clip(sim, "clip_left", np.array([x, rng.uniform(*CLIP_Y)]))
        self.place_clip(sim, "clip_right", np.array([x, -rng.uniform(*CLIP_Y)]))
        self.lay(sim, rng, np.array([x - rng.uniform(*CABLE_BEFORE), rng.uniform(*HEAD_Y)]))

    def evaluate_success(self, sim: SimHandle) -> bool:
        head_clip, tail_clip = clip_order(sim)
        return bool(through_clip(sim, "clip_left") and through_clip(sim, "clip_right")
                    and outside(sim, "head", head_clip) and outside(sim, "tail", tail_clip))

    def arms(self, sim: SimHandle) -> dict[str, str]:
        """Arm -> the end whose plug it takes: the one on its side."""
        arms = arms_by_side(sim.body_pos("cable_plug_head")[1], sim.body_pos("cable_plug_tail")[1])
        return dict(zip(arms, ENDS, strict=True))

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        head_clip, tail_clip = clip_order(sim)
        clips = {"head": head_clip, "tail": tail_clip}
        return {arm: [f"cable_plug_{end}", clips[end]] for arm, end in self.arms(sim).items()}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        head_clip, tail_clip = clip_order(sim)
        line = (sim.body_pos(head_clip)[:2] + sim.body_pos(tail_clip)[:2]) / 2
        along = sim.body_pos(head_clip)[:2] - sim.body_pos(tail_clip)[:2]
        along /= np.linalg.norm(along)  # the route's direction, from the tail's clip to the head's
        over = {"head": line + along * SPAN / 2, "tail": line - along * SPAN / 2}
        plan = {arm: route_keyframes(sim, end, over[end]) for arm, end in self.arms(sim).items()}
        return [{"left": a, "right": b} for a, b in zip(plan["left"], plan["right"], strict=True)]


def clip_order(sim: SimHandle) -> tuple[str, str]:
    """(the clip nearer the cable's head, the clip nearer its tail)."""
    head = sim.body_pos("cable_plug_head")[:2]
    near = [float(np.linalg.norm(sim.body_pos(c)[:2] - head)) for c in ("clip_left", "clip_right")]
    return ("clip_left", "clip_right") if near[0] <= near[1] else ("clip_right", "clip_left")


def outside(sim: SimHandle, end: str, clip: str, behind: np.ndarray | None = None) -> bool:
    """Whether the plug at ``end`` lies past ``clip`` on the far side from ``behind`` (xy; by default the other
    clip): routed through it, not short of it."""
    if behind is None:
        behind = sim.body_pos(next(c for c in ("clip_left", "clip_right") if c != clip))[:2]
    away = sim.body_pos(clip)[:2] - behind
    away /= np.linalg.norm(away)
    return bool(np.dot(sim.body_pos(f"cable_plug_{end}")[:2] - sim.body_pos(clip)[:2], away) > CABLE_SEGMENT)
