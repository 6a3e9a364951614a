"""The cable's plugs and clamp (sim/props/cable.py): an episode lays the cable where its welds hold it, the clamp
keeps the skill's far plug still, and a clip counts only a cable lying down its gap."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.props.cable import CLIP_GAP, POST_HALF, cable_points, through_clip


def plug_positions(env: ManipulationEnv) -> np.ndarray:
    return np.stack([env.sim.body_pos(f"cable_plug_{end}") for end in ("head", "tail")])


@pytest.mark.parametrize("task", ["cable_routing", "route_cable"])
def test_the_laid_cable_rests_where_its_welds_hold_it(task: str) -> None:
    """Plugs placed off their welds' relative pose would be pulled onto it by the constraint and jump by
    centimetres; the cable's bends relaxing moves a free plug by 3 mm at most."""
    env = ManipulationEnv(task, image_size=32)
    env.reset(seed=200_001, options={"render": False, "settle": False})
    laid, segments = plug_positions(env), cable_points(env.sim)
    env._settle(steps=100)  # the arms hold still above; only the cable and its plugs can move
    assert np.abs(plug_positions(env) - laid).max() < 0.005
    assert np.abs(cable_points(env.sim) - segments).max() < 0.005
    env.close()


def test_the_clamp_holds_the_far_plug_while_the_arm_pulls_the_cable() -> None:
    env = ManipulationEnv("route_cable", image_size=32)
    env.reset(seed=200_002, options={"render": False})
    clamped = env.sim.body_pos("cable_plug_head")
    for keyframe in env.expert_keyframes()[:4]:  # taken, lifted and carried over the clip
        env.step(env.action_from_keyframe(keyframe), render=False)
    assert env.sim.pinched("cable_plug_tail")
    assert np.linalg.norm(env.sim.body_pos("cable_plug_head") - clamped) < 0.005
    env.close()


def test_a_clip_counts_the_cable_only_down_its_gap() -> None:
    env = ManipulationEnv("cable_routing", image_size=32)
    env.reset(seed=200_003, options={"render": False})
    assert not through_clip(env.sim, "clip_left")  # the cable starts in front of the clips
    clip = env.sim.body_id("clip_left")
    points = cable_points(env.sim)
    nearest = points[np.argmin(np.abs(points[:, 1] - env.sim.body_pos("clip_left")[1]))]
    for dx, inside in ((0.0, True), (CLIP_GAP / 2 + POST_HALF[0], False)):  # in the gap; on a post
        env.sim.model.body_pos[clip, :2] = nearest[:2] + [dx, 0.0]
        mujoco.mj_kinematics(env.sim.model, env.sim.data)
        assert through_clip(env.sim, "clip_left") == inside
    env.close()
