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
