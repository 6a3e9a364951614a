"""Training curves: the loop's losses, learning rate, step time and validation figures reach TensorBoard event
files (read back with TensorBoard's own reader) and W&B's run, once per step even across a resume."""

from __future__ import annotations

import sys
import types
from pathlib import Path

import pytest
import torch

from bimanualshift.cli import main
from bimanualshift.training import loop
from bimanualshift.training.metric_log import TENSORBOARD_DIR, make_logger, numeric, open_logger


def _train(run_dir: Path, steps: int, log: str, crash_at: int = -1) -> dict:
    model = torch.nn.Linear(1, 1, bias=False)
    optimizer = torch.optim.SGD(model.parameters(), lr=0.5)

    def step_fn(step: int, gen: torch.Generator) -> dict[str, torch.Tensor]:
        if step == crash_at:
            raise KeyboardInterrupt
        return {"total": model.weight.sum() * 0 + float(step), "bc": model.weight.sum() * 0 + 1.0}

    def validate(step: int) -> dict[str, float]:
        return {"value": -step, "median_cm": 1.0 / (step + 1)}

    with open_logger(log, run_dir, {"lr": 0.5}) as logger:
        return loop.run_training(run_dir, model, optimizer, steps, step_fn, seed=0, checkpoint_every=2,
                                 validate_fn=validate, logger=logger, lr_factor=lambda step: 1.0 / (step + 1))


def _events(run_dir: Path) -> dict[str, list[tuple[int, float]]]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    acc = EventAccumulator(str(run_dir / TENSORBOARD_DIR))
    acc.Reload()
    return {tag: [(e.step, e.value) for e in acc.Scalars(tag)] for tag in acc.Tags()["scalars"]}


def test_tensorboard_gets_every_step_and_checkpoint(tmp_path: Path) -> None:
    _train(tmp_path, 4, "tensorboard")
    events = _events(tmp_path)
    assert events["loss/total"] == [(1, 0.0), (2, 1.0), (3, 2.0), (4, 3.0)]
    assert [v for _, v in events["train/lr"]] == pytest.approx([0.5, 0.25, 0.5 / 3, 0.125])
    assert len(events["train/step_time_s"]) == 4 and all(v >= 0 for _, v in events["train/step_time_s"])
    assert events["validation/value"] == [(0, 0.0), (2, -2.0), (4, -4.0)]
    assert events["validation/median_cm"][-1] == (4, pytest.approx(0.2))


def test_a_resumed_run_logs_each_step_once(tmp_path: Path) -> None:
    with pytest.raises(KeyboardInterrupt):
        _train(tmp_path, 6, "tensorboard", crash_at=3)  # steps 1-3 logged, the last checkpoint at step 2
    _train(tmp_path, 4, "tensorboard")  # resumes from the step-2 checkpoint and logs steps 3 and 4 again
    steps = [s for s, _ in _events(tmp_path)["loss/total"]]
    assert sorted(set(steps)) == [1, 2, 3, 4] and len(steps) == 4


def test_wandb_runs_offline_by_default_and_resumes_one_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[tuple[str, object]] = []

    class FakeRun:
        def log(self, values: dict, step: int) -> None:
            calls.append(("log", (step, values)))

        def finish(self) -> None:
            calls.append(("finish", None))

    def init(**kwargs: object) -> FakeRun:
        calls.append(("init", kwargs))
        return FakeRun()

    monkeypatch.setitem(sys.modules, "wandb", types.SimpleNamespace(init=init))
    monkeypatch.delenv("WANDB_MODE", raising=False)
    _train(tmp_path, 2, "wandb")
    init_kwargs = calls[0][1]
    assert isinstance(init_kwargs, dict) and init_kwargs["mode"] == "offline" and init_kwargs["resume"] == "allow"
    logged = [c[1] for c in calls if c[0] == "log"]
    assert (1, {"loss/total": 0.0, "loss/bc": 1.0, "train/lr": 0.5}) == (logged[1][0], {
        k: v for k, v in logged[1][1].items() if k != "train/step_time_s"})
    assert calls[-1][0] == "finish"
    _train(tmp_path / "again", 2, "wandb")
    assert [c[1]["id"] for c in calls if c[0] == "init"][0] != [c[1]["id"] for c in calls if c[0] == "init"][1]


def test_numeric_flattens_and_drops_what_is_not_a_number() -> None:
    assert numeric({"gate": {"translation_scale": 0.75, "chosen": True}, "note": "x", "nan": float("nan"),
                    "step": 3}) == {"gate/translation_scale": 0.75, "step": 3.0}


def test_unknown_logger_and_missing_package_say_what_to_do(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(ValueError, match="choose one of none, tensorboard, wandb"):
        make_logger("mlflow", tmp_path)
    monkeypatch.setitem(sys.modules, "wandb", None)  # an import of it fails
    with pytest.raises(ImportError, match=r"pip install 'bimanualshift\[wandb\]'"):
        make_logger("wandb", tmp_path)


@pytest.mark.parametrize("command", ["pretrain", "train", "refine", "bench"])
def test_every_trainer_takes_log(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main([command, "--help"])
    assert "--log {none,tensorboard,wandb}" in capsys.readouterr().out
