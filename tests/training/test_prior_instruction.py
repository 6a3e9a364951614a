"""`--prior-instruction`: what the frozen prior is asked, chosen on the training demos (``auto``), recorded with the
checkpoint and used again at inference; the Manager keeps the episode's instruction."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from bimanualshift.data.episode import list_episodes
from bimanualshift.encoders.text import default_text_encoder
from bimanualshift.methods.bimanualshift import load_bimanualshift
from bimanualshift.methods.prior_step import FrozenPriorStep
from bimanualshift.perception.arm_samples import build_arm_samples
from bimanualshift.priors import UnimanualPrior
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.training.configs import TrainConfig
from bimanualshift.training.prior_instruction import (
    CHOICE_DEMOS,
    OWN_PHRASING,
    choose_prior_instruction,
    median_errors,
    suite_instructions,
)
from bimanualshift.training.residual_trainer import PRIOR_INSTRUCTION_FILE, train_residual
from bimanualshift.utils.config_files import config_from_flat


@pytest.fixture(scope="module")
def prior_dir(demo_root: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tests.training.test_train_resume import pretrain, pretrain_cfg

    return pretrain(pretrain_cfg(demo_root, tmp_path_factory.mktemp("prior"), steps=2))


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

    best_dir = train_residual(cfg(2))
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
