"""The pretrained prior's model card: its reproduce commands name the data folders as a reader types them."""

from __future__ import annotations

from pathlib import Path

import pytest

from bimanualshift.training.pretrain import PretrainConfig, model_card


def test_reproduce_commands_show_folders_under_the_run_directory_relatively(tmp_path: Path,
                                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    cfg = PretrainConfig()
    cfg.dataset.tasks = ["push_button"]
    cfg.dataset.data = str(tmp_path / "data" / "suite")
    cfg.dataset.validation_data = "/elsewhere/suite_val"
    card = model_card(cfg, "peract", 100, 0.5, 10, 2, 60.0, 1000, train_seeds=10, val_seeds=2)
    assert "--out data/suite --workers 2" in card and "--data data/suite " in card
    assert str(tmp_path) not in card
    assert "--validation-data /elsewhere/suite_val" in card  # outside the run directory: kept as given
