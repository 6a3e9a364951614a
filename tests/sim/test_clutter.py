"""The clutter perturbation: look-alike pieces in the goal objects' colours that only the cameras see."""

from __future__ import annotations

import numpy as np
import pytest

from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.perturbations import Perturbations, preset
from bimanualshift.sim.props.clutter import CLEARANCE, CLUTTER_CLASS, CLUTTER_PREFIX

SEED = 5


def pieces(env: ManipulationEnv) -> list[int]:
    return [b for b in range(1, env.model.nbody) if env.model.body(b).name.startswith(CLUTTER_PREFIX)]


@pytest.mark.parametrize("task", ["push_two_buttons"])
def test_clutter_changes_what_the_cameras_see_and_nothing_else(task: str) -> None:
    plain = ManipulationEnv(task, image_size=64, perturbations=Perturbations())
    cluttered = ManipulationEnv(task, image_size=64, perturbations=preset("clutter"))
    obs, _ = cluttered.reset(seed=SEED)
    plain.reset(seed=SEED)
    # the same scene: every object where it is without the clutter, the same instruction (paired episodes)
    assert cluttered.task.instruction() == plain.task.instruction()
    np.testing.assert_array_equal(cluttered.data.qpos, plain.data.qpos)
    ids = pieces(cluttered)
    assert len(ids) == 4 and all(cluttered.model.geom_contype[cluttered.model.body_geomadr[b]] == 0 for b in ids)
    # on the table, in both arms' halves, clear of every object of the task
    xy = cluttered.data.xpos[ids, :2]
    assert (cluttered.data.xpos[ids, 2] > 0.8).all() and (xy[:, 1] > 0).any() and (xy[:, 1] < 0).any()
    task_bodies = [b for b in range(1, cluttered.model.nbody) if b not in ids
                   and int(cluttered.model.body_rootid[b]) in cluttered._task_roots]
    gaps = np.linalg.norm(xy[:, None] - cluttered.data.xpos[task_bodies, None, :2].transpose(1, 0, 2), axis=-1)
    assert gaps.min() >= CLEARANCE - 1e-9
    # painted in the goal objects' colours, and segmented as clutter, never as a goal's class
    goal_colours = {c for n, cs in cluttered.instance_colours().items() if not n.startswith(CLUTTER_PREFIX)
                    for c in cs}
    for b in ids:
        assert set(cluttered.instance_colours()[cluttered.model.body(b).name]) <= goal_colours
    clutter_class = cluttered.instances.classes.index(CLUTTER_CLASS)
    seen = sum((obs["cameras"][c]["class"] == clutter_class).sum() for c in cluttered.camera_names)
    assert seen > 0
    # the expert is the plain scene's: nothing touches the pieces
    for keyframe in cluttered.expert_keyframes():
        cluttered.step(cluttered.action_from_keyframe(keyframe), render=False)
    assert cluttered.success()
    plain.close()
    cluttered.close()


def test_clutter_is_seeded_and_round_trips_with_the_state() -> None:
    env = ManipulationEnv("push_two_buttons", image_size=32, perturbations=preset("clutter"))
    env.reset(seed=SEED, options={"render": False})
    first = env.data.xpos[pieces(env)].copy()
    state = env.get_state()
    env.reset(seed=SEED + 1, options={"render": False})
    assert not np.allclose(env.data.xpos[pieces(env)], first)
    env.set_state(state)
    np.testing.assert_array_equal(env.data.xpos[pieces(env)], first)
    env.reset(seed=SEED, options={"render": False})
    np.testing.assert_array_equal(env.data.xpos[pieces(env)], first)
    env.close()


def test_a_bad_clutter_count_is_refused() -> None:
    with pytest.raises(ValueError, match="clutter must be a count of pieces"):
        Perturbations(clutter=20)
