"""The shared training loop: resuming keeps the training time of the interrupted invocation."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest
import torch

from bimanualshift.training import loop


def _train(run_dir: Path, steps: int) -> dict:
    torch.manual_seed(0)
    model = torch.nn.Linear(2, 1)
    optimizer = torch.optim.SGD(model.parameters(), lr=0.1)

    def step_fn(step: int, gen: torch.Generator) -> dict[str, torch.Tensor]:
        x = torch.randn(4, 2, generator=gen)
        return {"total": model(x).pow(2).mean()}

    return loop.run_training(run_dir, model, optimizer, steps, step_fn, seed=0, checkpoint_every=2)


def test_resumed_run_reports_the_training_time_of_every_invocation(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    clock = itertools.count(0, 10)  # every call of time.time() is 10 s after the one before
    monkeypatch.setattr(loop.time, "time", lambda: float(next(clock)))
    first = _train(tmp_path, steps=2)
    resumed = _train(tmp_path, steps=4)
    assert first["training_time_s"] > 0
    assert resumed["history"][0]["step"] == 2  # the resumed run kept the first run's history
    assert resumed["training_time_s"] == resumed["history"][-1]["elapsed_s"]
    assert resumed["training_time_s"] > first["training_time_s"]


def test_history_logs_interval_means_and_validation_details(tmp_path: Path) -> None:
    model = torch.nn.Linear(1, 1, bias=False)
    optimizer = torch.optim.SGD(model.parameters(), lr=0.0)  # no learning: the loss is the step's own value

    def step_fn(step: int, gen: torch.Generator) -> dict[str, torch.Tensor]:
        return {"total": model.weight.sum() * 0 + float(step)}

    def validate(step: int) -> dict[str, float]:
        return {"value": -step, "median_cm": 1.0 / (step + 1)}

    out = loop.run_training(tmp_path, model, optimizer, 6, step_fn, seed=0, checkpoint_every=3,
                            validate_fn=validate)
    rows = out["history"]
    assert [r["step"] for r in rows] == [0, 3, 6]
    assert rows[1]["total"] == 1.0 and rows[2]["total"] == 4.0  # means of steps 0-2 and 3-5, not the last batch
    assert rows[2]["validation"] == -6 and rows[2]["validation_median_cm"] == 1 / 7
    assert out["best"]["step"] == 6


def test_patience_stops_a_run_that_no_longer_improves_and_a_resume_stays_stopped(tmp_path: Path) -> None:
    model = torch.nn.Linear(1, 1, bias=False)
    optimizer = torch.optim.SGD(model.parameters(), lr=0.0)
    values = {0: 5.0, 2: 1.0}  # the best comes at step 2; every later checkpoint is worse

    def step_fn(step: int, gen: torch.Generator) -> dict[str, torch.Tensor]:
        return {"total": model.weight.sum() * 0}

    def run(steps: int) -> dict:
        return loop.run_training(tmp_path, model, optimizer, steps, step_fn, seed=0, checkpoint_every=2,
                                 validate_fn=lambda step: values.get(step, 3.0), patience=3)

    out = run(20)
    assert out["best"]["step"] == 2 and out["stopped_early_at"] == 8  # 3 checkpoints (4, 6, 8) without a gain
    assert [r["step"] for r in out["history"]] == [0, 2, 4, 6, 8]
    again = run(40)
    assert again["stopped_early_at"] == 8 and [r["step"] for r in again["history"]] == [0, 2, 4, 6, 8]
    assert loop.run_training(tmp_path / "b", model, optimizer, 6, step_fn, seed=0, checkpoint_every=2,
                             validate_fn=lambda step: 1.0, patience=0)["stopped_early_at"] is None
