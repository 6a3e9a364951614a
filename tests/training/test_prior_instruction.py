"""`--prior-instruction`: what the frozen prior is asked, chosen on the training demos (``auto``) or per arm from
what the arm observes (``per_arm``), recorded with the checkpoint and used again at inference; the Manager keeps
the episode's instruction."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from bimanualshift.data.episode import list_episodes
from bimanualshift.data.frames import KeyframeObservation, scene_of_env
from bimanualshift.encoders.text import default_text_encoder
from bimanualshift.methods.bimanualshift import load_bimanualshift
from bimanualshift.methods.instruction_chooser import InstructionChooser, chooser_features
from bimanualshift.methods.prior_step import FrozenPriorStep
from bimanualshift.perception.arm_samples import ArmSamples, build_arm_samples
from bimanualshift.priors import UnimanualPrior
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.training.configs import TrainConfig
from bimanualshift.training.prior_instruction import (
    CHOICE_DEMOS,
    OWN_PHRASING,
    arm_labels,
    choose_prior_instruction,
    clipped_scores,
    median_errors,
    suite_instructions,
)
from bimanualshift.training.residual_trainer import PRIOR_INSTRUCTION_FILE, train_residual
from bimanualshift.utils.config_files import config_from_flat

DOOR = "open the oven door"


@pytest.fixture(scope="module")
def prior_dir(demo_root: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tests.training.test_train_resume import pretrain, pretrain_cfg

    return pretrain(pretrain_cfg(demo_root, tmp_path_factory.mktemp("prior"), steps=2))


def first_observation(task: str = "push_two_buttons", seed: int = 0) -> KeyframeObservation:
    """A task's first keyframe observation on a seed, as a policy meets it."""
    env = ManipulationEnv(task)
    try:
        obs, _ = env.reset(seed=seed)
        return KeyframeObservation.from_env(obs, scene_of_env(env))
    finally:
        env.close()


def first_instruction(task: str) -> str:
    env = ManipulationEnv(task)
    try:
        return env.reset(seed=0, options={"render": False, "settle": False})[1]["instruction"]
    finally:
        env.close()


def test_suite_instructions_are_the_pretraining_tasks_own(prior_dir: Path) -> None:
    assert suite_instructions(str(prior_dir)) == [first_instruction("push_button"), first_instruction("pick_cube")]


def test_choice_is_the_closest_instruction_only_past_the_margin(demo_root: Path, prior_dir: Path) -> None:
    step = FrozenPriorStep(UnimanualPrior.from_pretrained(prior_dir), default_text_encoder())
    paths = list_episodes(demo_root / "bimanual", "push_two_buttons")
    samples = build_arm_samples(paths, step.builder, step.prior.config.max_keyframes, desc=None)
    candidates = ["push the red button", "open the oven door", "sweep the dirt into the dustpan with the brush"]
    errors = median_errors(step, samples, [OWN_PHRASING, *candidates])
    assert len(set(errors)) > 1  # the text moves the prior's proposals
    chosen, table = choose_prior_instruction(step, samples, candidates, margin=0.0)
    assert [row["median_cm"] for row in table] == [round(100 * e, 2) for e in errors]
    best = int(np.argmin(errors))
    assert chosen == [OWN_PHRASING, *candidates][best]
    # no candidate beats the task's own phrasing by 100 %: the own phrasing stays
    assert choose_prior_instruction(step, samples, candidates, margin=1.0)[0] == OWN_PHRASING


def test_prior_step_asks_the_prior_the_chosen_instruction(prior_dir: Path) -> None:
    encoder = default_text_encoder()
    step = FrozenPriorStep(UnimanualPrior.from_pretrained(prior_dir), encoder, prior_instruction="open the oven door")
    assert torch.equal(step.text("push the red button"), torch.as_tensor(encoder.encode(["open the oven door"])))
    assert step.prior_texts(["a", "b"]) == ["open the oven door"] * 2
    own = FrozenPriorStep(step.prior, encoder)
    assert torch.equal(own.text("push the red button"), torch.as_tensor(encoder.encode(["push the red button"])))


def test_auto_choice_is_recorded_kept_on_resume_and_loaded(demo_root: Path, prior_dir: Path, tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    def cfg(steps: int, out: Path = tmp_path, instruction: str = "auto") -> TrainConfig:
        return config_from_flat(TrainConfig, prior=str(prior_dir), data=str(demo_root / "bimanual"),
                                validation_data=str(demo_root / "bimanual"), out=str(out), steps=steps,
                                checkpoint_every=2, demos=2, schedule="constant", prior_instruction=instruction)

    built: list[tuple[str, int]] = []

    def counted(paths: list[Path], *args: object, desc: str = "", **kwargs: object) -> ArmSamples:
        built.append((desc, len(paths)))
        return build_arm_samples(paths, *args, desc=desc, **kwargs)

    for module in ("residual_trainer", "residual_data"):
        monkeypatch.setattr(f"bimanualshift.training.{module}.build_arm_samples", counted)
    best_dir = train_residual(cfg(2))
    # the choice and the residual read the same training samples: the demos are voxelised once, the validation once
    assert built == [("voxelise train", 2), ("voxelise val", 2)]  # the roles read both before the residual
    record = json.loads((tmp_path / PRIOR_INSTRUCTION_FILE).read_text())
    texts = [row["instruction"] for row in record["candidates"]]
    assert texts == ["(the task's own)", *suite_instructions(str(prior_dir))]
    assert record["chosen_on_demos"] == min(2, CHOICE_DEMOS)
    errors = [row["median_cm"] for row in record["candidates"]]
    best = int(np.argmin(errors))
    expected = texts[best] if best and errors[best] < (1 - record["margin"]) * errors[0] else OWN_PHRASING
    assert record["prior_instruction"] == expected
    assert json.loads((best_dir / "config.json").read_text())["prior_instruction"] == expected

    def chosen_again(*args: object, **kwargs: object) -> None:
        raise AssertionError("a resumed run chose its prior instruction again")

    monkeypatch.setattr("bimanualshift.training.residual_trainer.choose_prior_instruction", chosen_again)
    train_residual(cfg(4))  # resumes with the recorded choice
    assert json.loads((tmp_path / "summary.json").read_text())["prior_instruction"] == expected

    # a given instruction is used as is, saved with the checkpoint and asked again at inference
    given = train_residual(cfg(2, tmp_path / "given", "open the oven door"))
    assert not (tmp_path / "given" / PRIOR_INSTRUCTION_FILE).exists()
    assert json.loads((given / "config.json").read_text())["prior_instruction"] == "open the oven door"
    assert load_bimanualshift(given, default_text_encoder()).prior_step.prior_instruction == "open the oven door"


def fake_samples(episode: list[int], arm: list[str]) -> ArmSamples:
    n = len(episode)
    return ArmSamples(voxels=None, proprio=np.zeros((n, 9), np.float32), instructions=["push the buttons"] * n,
                      action_pos=np.zeros((n, 3), np.float32), action_quat=np.tile([0, 0, 0, 1.0], (n, 1)),
                      gripper_open=np.ones(n, np.int64), ignore_collisions=np.zeros(n, np.int64),
                      episode=np.asarray(episode), keyframe=np.zeros(n, np.int64), arm=arm,
                      other_proprio=np.zeros((n, 8), np.float32))


def test_first_episodes_keeps_every_field_of_the_first_episodes_samples() -> None:
    samples = fake_samples([0, 0, 1, 2, 2], ["left", "right", "left", "left", "right"])
    samples.proprio[:, 0] = np.arange(5)
    first = samples.first_episodes(2)
    assert first.episode.tolist() == [0, 0, 1] and first.arm == ["left", "right", "left"]
    assert first.proprio[:, 0].tolist() == [0, 1, 2] and len(first.instructions) == 3 and first.voxels is None
    assert len(samples.first_episodes(10)) == 5


def test_arm_labels_give_one_instruction_to_the_arms_it_helps_past_the_margin() -> None:
    samples = fake_samples([0, 0, 0, 0, 1, 1], ["left", "left", "right", "right", "left", "right"])
    scores = {OWN_PHRASING: np.array([2.0, 2.0, 1.0, 1.0, 2.0, 2.0]),
              DOOR: np.array([1.0, 1.0, 0.9, 0.9, 1.9, 2.5]),
              # better than DOOR on demo 1's left arm, but it gains less in all: one instruction besides the own
              "a near-synonym": np.array([1.45, 1.45, 1.0, 1.0, 1.6, 2.0])}
    # demo 0's left arm: 1.0 < 0.75 * 2; its right arm: 0.9 is not 25 % below 1.0; demo 1's left: 1.9 is not
    assert arm_labels(scores, samples, margin=0.25) == [DOOR, DOOR] + [OWN_PHRASING] * 4
    assert arm_labels(scores, samples, margin=0.0) == [DOOR, DOOR, DOOR, DOOR, DOOR, OWN_PHRASING]
    # nothing beats the own phrasing: every arm keeps it
    assert arm_labels({OWN_PHRASING: scores[OWN_PHRASING]}, samples) == [OWN_PHRASING] * 6


def test_clipped_scores_clip_as_the_output_gate() -> None:
    scores = clipped_scores(np.array([0.0, 0.025, 0.05, 0.4]), np.array([0.0, 0.0, 90.0, 10.0]))
    assert np.allclose(scores[:3], [0.0, 0.5, 2.0])
    assert scores[3] == pytest.approx(1.0 + np.deg2rad(10.0) / 0.35)


def test_prior_step_asks_each_arm_its_chooser_pick(prior_dir: Path) -> None:
    encoder = default_text_encoder()
    features = np.array([[1.0, 0.0], [-1.0, 0.0], [2.0, 1.0], [-2.0, 1.0]])
    chooser = InstructionChooser.fit(features, [DOOR, OWN_PHRASING, DOOR, OWN_PHRASING])
    step = FrozenPriorStep(UnimanualPrior.from_pretrained(prior_dir), encoder, instruction_chooser=chooser)
    assert step.prior_texts(["a", "b"], np.array([[3.0, 0.0], [-3.0, 0.0]])) == [DOOR, "b"]
    assert torch.equal(step.text("b", np.array([3.0, 0.0])), torch.as_tensor(encoder.encode([DOOR])))
    assert torch.equal(step.text("b", np.array([-3.0, 0.0])), torch.as_tensor(encoder.encode(["b"])))
    with pytest.raises(ValueError, match="needs each arm's features"):
        step.prior_texts(["a"])


def left_arm_prefers_the_door(monkeypatch: pytest.MonkeyPatch) -> None:
    """The prior's errors made to favour DOOR on the left arm only (the wiring under test, not the tiny prior)."""
    def errors(prior_step: FrozenPriorStep, samples: ArmSamples, texts: list[str]) -> tuple[np.ndarray, np.ndarray]:
        left = np.asarray(samples.arm) == "left"
        door = np.asarray(texts) == DOOR
        return np.where(left & door, 0.01, 0.04), np.where(left & door, 1.0, 15.0)

    monkeypatch.setattr("bimanualshift.training.prior_instruction.teacher_forced_errors", errors)


def test_per_arm_choice_learns_the_role_is_recorded_and_loaded(demo_root: Path, prior_dir: Path, tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    left_arm_prefers_the_door(monkeypatch)
    monkeypatch.setattr("bimanualshift.training.residual_trainer.suite_instructions", lambda prior: [DOOR, "x"])

    def cfg(steps: int) -> TrainConfig:
        return config_from_flat(TrainConfig, prior=str(prior_dir), data=str(demo_root / "bimanual"),
                                validation_data=str(demo_root / "bimanual"), out=str(tmp_path), steps=steps,
                                checkpoint_every=2, demos=2, schedule="constant", prior_instruction="per_arm")

    best_dir = train_residual(cfg(2))
    record = json.loads((tmp_path / PRIOR_INSTRUCTION_FILE).read_text())
    assert [row["instruction"] for row in record["candidates"]] == ["(the task's own)", DOOR, "x"]
    assert set(record["label_samples"]) == {"(the task's own)", DOOR}
    assert record["train_accuracy"] == 1.0  # an arm's own frame tells left from right in these scenes
    saved = json.loads((best_dir / "config.json").read_text())["instruction_chooser"]
    assert saved == record["instruction_chooser"]
    policy = load_bimanualshift(best_dir, default_text_encoder())
    chooser = policy.prior_step.instruction_chooser
    assert chooser is not None and chooser.to_dict() == saved

    # at a real keyframe the loaded policy asks the left arm's prior DOOR and the right arm's its own instruction
    frame = first_observation()
    per_arm = policy.prior_step.builder.build(frame)
    picks = {arm: chooser.choose(chooser_features(o.goal, o.proprio, o.other_proprio))[0] for arm, o in per_arm.items()}
    assert picks == {"left": DOOR, "right": OWN_PHRASING}
    steps = policy.prior_step.run(frame)
    assert {arm: s.asked for arm, s in steps.items()} == {"left": DOOR, "right": ""}
    policy.reset()
    policy.decide(frame)  # the keyframe log says which arm's prior was asked what
    assert [a.get("prior_asked") for a in policy.keyframe_log()["arms"]] == [DOOR, None]

    def chosen_again(*args: object, **kwargs: object) -> None:
        raise AssertionError("a resumed run chose its instructions again")

    monkeypatch.setattr("bimanualshift.training.residual_trainer.choose_arm_instructions", chosen_again)
    train_residual(cfg(4))
    assert json.loads((tmp_path / "summary.json").read_text())["instruction_chooser"] == saved
