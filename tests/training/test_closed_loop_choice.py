"""`train --select-rollouts N`: candidates kept by teacher-forced value, rolled out, the most successful handed on."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import bimanualshift.training.closed_loop_choice as choice_module
from bimanualshift.training.closed_loop_choice import (
    ROLLOUTS_FILE,
    candidate_folders,
    choose_by_rollouts,
    chosen_index,
    keep_candidate,
    selection_seeds,
)
from bimanualshift.training.configs import TrainConfig
from bimanualshift.training.residual_trainer import train_residual
from bimanualshift.utils.config_files import config_from_flat

TASK = "push_two_buttons"


def _writer(step: int, value: float):  # noqa: ANN202
    def save(folder: Path) -> None:
        folder.mkdir(parents=True)
        (folder / "config.json").write_text(json.dumps({"trained_steps": step, "validation_loss": value}))
    return save


def test_each_stretch_of_the_run_keeps_its_lowest_value(tmp_path: Path) -> None:
    # a 12-step run in 3 stretches: steps 0-3, 4-7, 8-12
    for step, value in ((0, 0.9), (2, 0.5), (4, 0.7), (6, 0.95), (8, 0.4), (10, 0.3), (12, 0.35)):
        keep_candidate(tmp_path, step, value, parts=3, total_steps=12, save=_writer(step, value))
    kept = [json.loads((f / "config.json").read_text())["trained_steps"] for f in candidate_folders(tmp_path)]
    assert kept == [10, 2, 4]  # lowest value first; 8 was kept, then displaced by 10 in its stretch
    assert not keep_candidate(tmp_path, 6, 0.8, parts=3, total_steps=12, save=_writer(6, 0.8))


def test_the_choice_is_the_most_successes_then_stages_then_the_lower_value() -> None:
    rows = [{"successes": 3, "stages_done": 5}, {"successes": 4, "stages_done": 4}, {"successes": 4, "stages_done": 4}]
    assert chosen_index(rows) == 1
    rows[2]["stages_done"] = 6
    assert chosen_index(rows) == 2
    assert chosen_index([{"successes": 0, "stages_done": 0}] * 3) == 0


def test_selection_scenes_are_apart_from_the_benchmarks_validation_rollouts() -> None:
    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.bench import VALIDATION_ROLLOUT_START

    bench = set(split_seeds("validation", 1000, VALIDATION_ROLLOUT_START))
    assert not bench & set(selection_seeds(1000)) and min(selection_seeds(1)) >= 100_000  # validation split


@pytest.mark.slow
def test_a_run_rolls_its_candidates_out_and_hands_on_the_most_successful(
        demo_root: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from tests.training.test_train_resume import pretrain, pretrain_cfg

    prior = pretrain(pretrain_cfg(demo_root, tmp_path / "prior", steps=2))
    run = tmp_path / "run"
    best = train_residual(config_from_flat(
        TrainConfig, prior=str(prior), data=str(demo_root / "bimanual"), validation_data=str(demo_root / "bimanual"),
        out=str(run), steps=4, checkpoint_every=2, demos=2, retrieval=True, retrieval_threshold=-1.0,
        select_rollouts=1, select_candidates=2, select_max_keyframes=2))
    summary = json.loads((run / "summary.json").read_text())
    record = summary["closed_loop_choice"]
    folders = candidate_folders(run)
    # 3 validated checkpoints (steps 0, 2, 4) in 2 stretches: step 0 alone in the first, the lower of 2 and 4
    assert len(folders) == len(record["candidates"]) == 2
    assert [r["episodes"] for r in record["candidates"]] == [1, 1]
    values = [r["validation_loss"] for r in record["candidates"]]
    assert values == sorted(values)
    history = {h["step"]: h["validation"] for h in summary["history"]}
    later = min((2, 4), key=lambda step: (history[step], step))
    assert sorted(r["step"] for r in record["candidates"]) == [0, later]
    chosen = json.loads((best / "config.json").read_text())
    assert chosen["trained_steps"] == record["chosen_step"]
    for folder in folders:  # each candidate was rolled out on the selection scenes, and gated like best/
        episodes = json.loads((folder / ROLLOUTS_FILE).read_text())
        assert episodes["seeds"] == selection_seeds(1) and all(1 <= e["keyframes"] <= 2 for e in episodes["episodes"])
        assert "output_scale" in json.loads((folder / "config.json").read_text())

    # The choice follows the rollouts: in the saved outcomes, let the chosen candidate fail its scene and the
    # other solve it; the choice is made again from them (nothing is rolled out again) and hands the other on.
    for folder in folders:
        won = json.loads((folder / "config.json").read_text())["trained_steps"] != record["chosen_step"]
        saved = json.loads((folder / ROLLOUTS_FILE).read_text())
        saved["episodes"] = [{**e, "success": won, "stages_done": int(won)} for e in saved["episodes"]]
        (folder / ROLLOUTS_FILE).write_text(json.dumps(saved))
    other = next(f for f in folders if json.loads((f / "config.json").read_text())["trained_steps"]
                 != record["chosen_step"])

    def no_rollouts(*args: object, **kwargs: object) -> None:
        raise AssertionError("rolled out again")

    monkeypatch.setattr("bimanualshift.utils.workers.run_jobs", no_rollouts)
    again = choose_by_rollouts(run, TASK, episodes=1, max_keyframes=2)
    assert again["chosen_step"] == json.loads((other / "config.json").read_text())["trained_steps"]
    assert json.loads((run / "best" / "config.json").read_text())["closed_loop_choice"] == {"successes": 1,
                                                                                         "episodes": 1}
    assert not (run / "best.choosing").exists() and not (run / "best.previous").exists()


def test_a_run_without_candidates_is_refused_with_what_to_do(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="--select-rollouts"):
        choice_module.choose_by_rollouts(tmp_path, TASK, episodes=2)
    with pytest.raises(ValueError, match="--select-rollouts must be >= 0"):
        train_residual(TrainConfig(select_rollouts=-1, out=str(tmp_path / "r")))
