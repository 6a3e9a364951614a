"""Perturbation switches change what the cameras see; the mirrored layout stays solvable."""

from __future__ import annotations

import numpy as np
import pytest

from bimanualshift.core.colours import TRAIN_COLOURS, UNSEEN_COLOURS
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.perturbations import PRESETS, REGIME_PRESETS, Perturbations, preset

from suite_tasks import suite_tasks

TASK, SEED = "push_two_buttons", 3


def front_image(p: Perturbations) -> tuple[np.ndarray, ManipulationEnv]:
    env = ManipulationEnv(TASK, image_size=64, perturbations=p)
    env.reset(seed=SEED, options={"render": False})
    return env.cameras.render(env.data, depth_and_segmentation=False)["front"].rgb, env


@pytest.fixture(scope="module")
def baseline() -> np.ndarray:
    image, env = front_image(Perturbations())
    env.close()
    return image


@pytest.mark.parametrize("name", [n for n in (*PRESETS, *REGIME_PRESETS) if n != "none"])
def test_every_preset_changes_the_front_camera(name: str, baseline: np.ndarray) -> None:
    image, env = front_image(preset(name))
    env.close()
    changed = np.abs(image.astype(int) - baseline.astype(int)).max(axis=-1) > 10
    assert changed.mean() > 0.001, f"{name} changed only {changed.mean():.4%} of the pixels"


def test_unseen_colours_never_overlap_training_colours() -> None:
    assert not set(TRAIN_COLOURS) & set(UNSEEN_COLOURS)
    assert len(TRAIN_COLOURS) == 18
    _, env = front_image(preset("unseen_colours"))
    assert set(env.task.episode["colours"]) <= set(UNSEEN_COLOURS)
    env.close()


# Mirrored, Pouring Water's left arm pours towards its right, the side the UR5e reaches worst (its single-arm
# skill fails a third of its seeds there, so pour_cup samples only the other side). No study mirrors this task.
MIRROR_EXPERT_FAILURES = {"pouring_water": "the left arm's pour towards its right is not reached (issue 53)"}


@pytest.mark.slow
@pytest.mark.parametrize("task", suite_tasks(bimanual=True))
def test_swap_sides_mirrors_the_layout_and_the_expert_still_succeeds(task: str, request: pytest.FixtureRequest
                                                                     ) -> None:
    plain = ManipulationEnv(task, image_size=32, perturbations=Perturbations())
    mirrored = ManipulationEnv(task, image_size=32, perturbations=preset("swap_sides"))
    plain.reset(seed=SEED, options={"render": False})
    mirrored.reset(seed=SEED, options={"render": False})
    prefix = mirrored.task.particle_prefix
    particles = [b for b in mirrored._task_roots if prefix and mirrored.model.body(b).name.startswith(prefix)]
    for body in set(mirrored._task_roots) - set(particles):  # every object of the task, at its mirrored place
        np.testing.assert_allclose(mirrored.data.xpos[body], plain.data.xpos[body] * [1, -1, 1], atol=2e-3)
    if particles:  # poured balls jostle as they settle: the water as a whole at its mirrored place
        np.testing.assert_allclose(mirrored.data.xpos[particles].mean(0),
                                   plain.data.xpos[particles].mean(0) * [1, -1, 1], atol=2e-3)
    assert mirrored.task.instruction() == plain.task.instruction()
    if task in MIRROR_EXPERT_FAILURES:  # the layout above still holds; the expert's failure is known (strict)
        request.applymarker(pytest.mark.xfail(reason=MIRROR_EXPERT_FAILURES[task], strict=True))
    for keyframe in mirrored.expert_keyframes():
        mirrored.step(mirrored.action_from_keyframe(keyframe), render=False)
    assert mirrored.success(), f"{task}: the expert failed on the mirrored layout"
    plain.close()
    mirrored.close()


def test_bad_perturbations_are_rejected_with_a_clear_message() -> None:
    with pytest.raises(ValueError, match="lighting must be a fraction"):
        Perturbations(lighting=2.0)
    with pytest.raises(ValueError, match="unknown perturbation"):
        Perturbations.from_dict({"fog": True})
    with pytest.raises(KeyError, match="unknown perturbation preset 'fog'"):
        preset("fog")
