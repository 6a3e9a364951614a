"""A learning-rate schedule that resumes exactly, and pretraining that continues from a trained prior."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file

from bimanualshift.training.checkpoint import latest_checkpoint
from bimanualshift.training.optim import MIN_LR_FACTOR, lr_factor
from bimanualshift.training.pretrain import first_demos, pretrain
from tests.training.test_train_resume import pretrain_cfg


def test_cosine_warms_up_then_decays_to_its_floor() -> None:
    assert [lr_factor("cosine", s, 10, 2) for s in (0, 1)] == [0.5, 1.0]
    assert lr_factor("cosine", 2, 10, 2) == pytest.approx(1.0)
    assert lr_factor("cosine", 10, 10, 2) == pytest.approx(MIN_LR_FACTOR)
    assert lr_factor("constant", 7, 10) == 1.0
    with pytest.raises(ValueError, match="unknown learning-rate schedule"):
        lr_factor("step", 0, 10)


def _cosine(cfg):  # noqa: ANN001, ANN202
    return replace(cfg, optim=replace(cfg.optim, schedule="cosine", warmup_steps=1))


def test_a_scheduled_run_resumes_to_the_uninterrupted_weights(demo_root: Path, tmp_path: Path) -> None:
    pretrain(_cosine(pretrain_cfg(demo_root, tmp_path / "a", steps=2)))
    pretrain(_cosine(pretrain_cfg(demo_root, tmp_path / "a", steps=4)))
    pretrain(_cosine(pretrain_cfg(demo_root, tmp_path / "b", steps=4)))
    resumed = load_file(str(latest_checkpoint(tmp_path / "a") / "model.safetensors"))
    straight = load_file(str(latest_checkpoint(tmp_path / "b") / "model.safetensors"))
    constant = pretrain_cfg(demo_root, tmp_path / "c", steps=4)
    pretrain(constant)
    other = load_file(str(latest_checkpoint(tmp_path / "c") / "model.safetensors"))
    assert all(torch.equal(v, resumed[k]) for k, v in straight.items())
    assert not all(torch.equal(v, other[k]) for k, v in straight.items())  # the schedule changed the steps


def test_pretraining_continues_from_a_trained_prior(demo_root: Path, tmp_path: Path) -> None:
    first = pretrain(pretrain_cfg(demo_root, tmp_path / "first", steps=2))
    cfg = pretrain_cfg(demo_root, tmp_path / "second", steps=0)
    cfg = replace(cfg, network=replace(cfg.network, init_from=str(first), size="default"))
    second = pretrain(cfg)  # no step: the candidate at step 0 is the starting point itself
    a, b = load_file(str(first / "model.safetensors")), load_file(str(second / "model.safetensors"))
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    config = json.loads((second / "config.json").read_text())
    earlier = json.loads((first / "config.json").read_text())
    assert config["initialised_from"] == str(first) and config["dim"] == earlier["dim"]  # its size, not "default"
    assert config["trained_steps"] == earlier["trained_steps"]
    with pytest.raises(ValueError, match="is a peract prior, not diffusion"):
        pretrain(replace(cfg, network=replace(cfg.network, prior="dp")))


def test_first_demos_are_the_lowest_seeds_so_smaller_volumes_are_subsets() -> None:
    paths = [Path(f"data/t/episode_{s}.h5") for s in (10, 2, 100000, 1, 33)]  # glob order is by name, not seed
    assert [p.stem for p in first_demos(paths, 3)] == ["episode_1", "episode_2", "episode_10"]
    assert len(first_demos(paths, 0)) == 5 and first_demos(paths, 9)[-1].stem == "episode_100000"


def test_pretraining_on_fewer_demos_per_task_is_recorded(demo_root: Path, tmp_path: Path) -> None:
    cfg = pretrain_cfg(demo_root, tmp_path / "one", steps=0)
    best = pretrain(replace(cfg, dataset=replace(cfg.dataset, episodes_per_task=1)))
    tasks = json.loads((best / "config.json").read_text())["pretrain_tasks"]
    assert json.loads((best / "config.json").read_text())["train_episodes"] == len(tasks)  # one demo per task
    assert "--episodes-per-task 1" in (best / "README.md").read_text()  # the model card reproduces it
    with pytest.raises(ValueError, match="episodes-per-task"):
        pretrain(replace(cfg, dataset=replace(cfg.dataset, episodes_per_task=-1)))


def test_continuing_a_cloud_prior_may_read_a_denser_cloud(demo_root: Path, tmp_path: Path) -> None:
    first = pretrain(pretrain_cfg(demo_root, tmp_path / "rvt", steps=0, prior="rvt"))
    cfg = pretrain_cfg(demo_root, tmp_path / "denser", steps=0, prior="rvt")
    cfg = replace(cfg, network=replace(cfg.network, init_from=str(first), model={"num_points": 512}))
    config = json.loads((pretrain(cfg) / "config.json").read_text())
    assert config["num_points"] == 512 and json.loads((first / "config.json").read_text())["num_points"] == 256
