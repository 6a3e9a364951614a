"""Every registered task: seeded determinism, state round trip, invalid actions, expert success."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from bimanualshift.core.goal_nouns import extract_goal_nouns, split_prompt
from bimanualshift.sim.env import InvalidActionError, ManipulationEnv
from bimanualshift.sim.task import TASKS, SimHandle, Task, register_task
from bimanualshift.sim.task_registry import task_names

from suite_tasks import suite_tasks

# Every task built for a robot, and two of the Panda tasks' UR5e variants: these tests cover what a variant changes
# (the robot) on both specs.
ALL_TASKS = suite_tasks()


@pytest.fixture(scope="module", params=ALL_TASKS)
def env(request: pytest.FixtureRequest) -> Iterator[ManipulationEnv]:
    e = ManipulationEnv(request.param, image_size=64)
    yield e
    e.close()


def test_registry_has_bimanual_and_single_arm_tasks() -> None:
    assert set(task_names(bimanual=True, robot="panda")) == {
        "lift_ball", "push_two_buttons", "pick_up_plate", "take_tray_out_of_oven", "straighten_rope",
        "sweep_to_dustpan", "buttons_then_lift_ball"}
    assert len(task_names(bimanual=False, robot="panda")) >= 8
    # a task another robot may run is registered again under "task@robot", on that robot's spec
    variants = {f"{t}@ur5e" for t in task_names() if "ur5e" in TASKS[t].other_robots}
    native = {t for t in task_names() if TASKS[t].robot == "ur5e" and "@" not in t}  # built for the twin
    assert set(task_names(robot="ur5e")) == variants | native and {"vegetable_sorting", "block_threading"} <= native
    assert TASKS["push_button@ur5e"].robot == "ur5e" and TASKS["push_button@ur5e"].name == "push_button@ur5e"
    # the added-skill split is the Panda suite's: on the twin's suite a variant counts in the one mean
    assert TASKS["hold_dustpan"].added_skill and not TASKS["hold_dustpan@ur5e"].added_skill
    with pytest.raises(ValueError, match="registered twice"):
        register_task("push_button")(TASKS["push_button"])


def test_scene_has_one_robot_per_arm(env: ManipulationEnv) -> None:
    # Single-arm demonstrations must never contain a second arm.
    assert len(env.scene.robots) == len(env.arm_names) == (2 if env.task.bimanual else 1)
    arms = [n for n in env.instances.names if n.startswith("arm_")]
    assert arms == [f"arm_{a}" for a in env.arm_names]


def test_seeded_reset_is_deterministic(env: ManipulationEnv) -> None:
    a, _ = env.reset(seed=7)
    state_a = env.get_state()
    env.reset(seed=8)
    b, _ = env.reset(seed=7)
    assert a["instruction"] == b["instruction"]
    np.testing.assert_array_equal(env.get_state()["qpos"], state_a["qpos"])
    for cam in env.camera_names:
        np.testing.assert_array_equal(a["cameras"][cam]["rgb"], b["cameras"][cam]["rgb"])


def test_different_seeds_give_different_scenes(env: ManipulationEnv) -> None:
    env.reset(seed=1)
    s1 = env.get_state()
    env.reset(seed=2)
    s2 = env.get_state()
    assert not (np.allclose(s1["body_pos"], s2["body_pos"]) and s1["episode"] == s2["episode"])


def test_state_round_trip(env: ManipulationEnv) -> None:
    env.reset(seed=3)
    state = env.get_state()
    image = env.render()
    env.reset(seed=4)
    env.set_state(state)
    np.testing.assert_array_equal(env.render(), image)
    assert env.get_state()["episode"] == state["episode"]


def test_invalid_actions_raise_clear_errors(env: ManipulationEnv) -> None:
    env.reset(seed=0, options={"render": False})
    n = len(env.arm_names)
    good = np.stack([kf.to_vector() for kf in env.expert_keyframes()[0].values()])
    bad = good.copy()
    bad[0, 1] = np.nan
    with pytest.raises(InvalidActionError, match="NaN"):
        env.step(bad)
    with pytest.raises(InvalidActionError, match="shape"):
        env.step(good[:, :7])
    far = good.copy()
    far[n - 1, 0] = 5.0
    with pytest.raises(InvalidActionError, match="outside the workspace"):
        env.step(far)


# Seeds of this check that an expert below 100 % misses (results/experts*.json have the rates). Strict: a fix shows
# here as an unexpected pass.
KNOWN_EXPERT_FAILURES: dict[tuple[str, int], str] = {}
# One seed per task: every expert's 100-seed record is in results/experts*.json; this catches a change that breaks it.
EXPERT_SEED = 11


@pytest.mark.slow
def test_expert_succeeds_reaching_every_stage_in_order(env: ManipulationEnv, request: pytest.FixtureRequest) -> None:
    """The expert succeeds, and (stage-wise success) the count of stages done never falls, rises before the end
    and ends with all of them. One episode checks both: an expert episode is the slow part."""
    seed = EXPERT_SEED
    if (env.task.name, seed) in KNOWN_EXPERT_FAILURES:
        request.applymarker(pytest.mark.xfail(reason=KNOWN_EXPERT_FAILURES[env.task.name, seed], strict=True))
    env.reset(seed=seed, options={"render": False})
    assert not env.success()
    done = [env.step(env.action_from_keyframe(keyframe), render=False)[4]["stages_done"]
            for keyframe in env.expert_keyframes()]
    assert env.success(), f"{env.task.name} expert failed on seed {seed}"
    if env.task.stage_names:
        assert done == sorted(done) and done[-1] == len(env.task.stage_names), done
        assert done[0] < done[-1]  # the stages are reached one after another, not all at the end


class ScriptedStages(Task):
    """A task whose stage checks follow a script, to test the latching on its own."""

    name = "scripted"
    bimanual = True
    stage_names = ("a", "b", "c")

    def __init__(self, script: list[list[bool]]) -> None:
        super().__init__()
        self.script = iter(script)

    def scene_xml(self) -> str:
        return ""

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        self.episode = {}

    def instruction(self) -> str:
        return "do it"

    def expert_keyframes(self, sim: SimHandle) -> list:
        return []

    def evaluate_success(self, sim: SimHandle) -> bool:
        return False

    def evaluate_stages(self, sim: SimHandle) -> list[bool]:
        return next(self.script)


def test_stages_latch_in_order_and_success_completes_them() -> None:
    task = ScriptedStages([[False, True, False], [True, False, False], [False, True, False], [False, False, False],
                           [False, False, False]])
    # b before a does not count; a then b counts; a stage once reached stays reached.
    assert [task.update_stages(None, False) for _ in range(4)] == [0, 1, 2, 2]  # type: ignore[arg-type]
    assert task.update_stages(None, True) == 3  # type: ignore[arg-type]
    bad = ScriptedStages([[True]])
    with pytest.raises(ValueError, match="returned 1 values for 3 stages"):
        bad.update_stages(None, False)  # type: ignore[arg-type]


def test_goal_nouns_cover_the_instructions_object(env: ManipulationEnv) -> None:
    """Tasks may add goal nouns (a tray task also needs the oven seen), never drop the instruction's object."""
    for seed in range(3):
        env.reset(seed=seed, options={"render": False})
        instruction = env.task.instruction()
        assert set(extract_goal_nouns(instruction)) <= set(env.task.goal_nouns()), instruction


def test_every_goal_noun_is_a_class_of_the_scene(env: ManipulationEnv) -> None:
    """The simulator segmenter finds a goal by its class: a goal noun no instance carries is never seen, and the
    projection would leave each arm only itself and the table."""
    env.reset(seed=0, options={"render": False})
    for prompt in env.task.goal_nouns():
        assert split_prompt(prompt)[1] in env.instances.classes, (prompt, env.instances.classes)


def test_every_colour_prompt_names_a_painted_object_of_its_class(env: ManipulationEnv) -> None:
    """"navy button" must find a navy button: the projection would otherwise keep nothing of the goal."""
    for seed in range(3):
        env.reset(seed=seed, options={"render": False})
        painted = env.instance_colours()
        for prompt in env.task.goal_nouns():
            colour, noun = split_prompt(prompt)
            if colour is None:
                continue
            owners = [n for n, cls in zip(env.instances.names, (env.instances.classes[c] for c in
                                                                env.instances.instance_class)) if cls == noun]
            assert any(colour in painted.get(n, []) for n in owners), (env.task.instruction(), painted)


def test_unknown_task_error() -> None:
    with pytest.raises(KeyError, match="unknown task 'nope'; registered tasks"):
        ManipulationEnv("nope")


def test_a_tabulated_task_has_its_papers_tier_and_keyframe_count(env: ManipulationEnv) -> None:
    task = env.task
    assert (task.tier == "") == (task.paper_keyframes == 0)
    if not task.paper_keyframes:
        return
    assert task.tier in ("Coordination", "Collaboration", "Precision")
    env.reset(seed=3, options={"render": False, "settle": False})
    assert len(env.expert_keyframes()) == task.paper_keyframes
