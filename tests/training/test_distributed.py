"""Data-parallel pretraining: two torchrun processes on gloo follow one process at the same (global) batch."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file

from bimanualshift.training.checkpoint import latest_checkpoint
from bimanualshift.training.distributed import Distributed
from bimanualshift.training.pretrain import pretrain
from tests.training.test_train_resume import pretrain_cfg

STEPS = 4


def losses(run: Path) -> list[float]:
    history = json.loads((run / "history.json").read_text())["history"]
    return [h["total"] for h in history if "total" in h]


def test_shards_split_the_global_batch_evenly() -> None:
    index = torch.arange(8)
    parts = [Distributed(rank, 2).shard(8, index) for rank in range(2)]
    assert torch.equal(torch.cat(parts), index)
    with pytest.raises(ValueError, match="multiple of the 2 processes"):
        Distributed(0, 2).shard(5, torch.arange(5))


@pytest.mark.slow
def test_two_gloo_processes_give_one_process_loss_curve(demo_root: Path, tmp_path: Path) -> None:
    cfg = pretrain_cfg(demo_root, tmp_path / "one", steps=STEPS)
    cfg.optim.checkpoint_every, cfg.optim.batch_size = 1, 4
    pretrain(cfg)
    two = tmp_path / "two"
    command = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", "2",
               "-m", "bimanualshift.cli", "pretrain", "--prior", "peract", "--size", "debug",
               "--tasks", "push_button", "pick_cube", "--data", cfg.dataset.data,
               "--validation-data", cfg.dataset.validation_data,
               "--out", str(two), "--steps", str(STEPS), "--batch-size", "4", "--checkpoint-every", "1"]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    one_curve, two_curve = losses(tmp_path / "one"), losses(two)
    assert len(one_curve) == len(two_curve) == STEPS
    assert two_curve == pytest.approx(one_curve, rel=1e-4, abs=1e-5)
    assert json.loads((two / "summary.json").read_text())["processes"] == 2
    one_w = load_file(str(latest_checkpoint(tmp_path / "one") / "model.safetensors"))
    two_w = load_file(str(latest_checkpoint(two) / "model.safetensors"))
    # LAMB, like Adam, divides each gradient entry by its own running scale: for an entry whose gradient is almost
    # zero it turns the float rounding of a two-way sum into a step of up to lr, so weights agree to steps x lr.
    lr_bound = STEPS * cfg.optim.lr
    for key, value in one_w.items():
        assert (two_w[key] - value).abs().max() <= lr_bound, key
    agree = sum(torch.allclose(two_w[k], v, rtol=1e-4, atol=1e-5) for k, v in one_w.items())
    assert agree >= len(one_w) - 2  # all but such near-zero-gradient tensors agree to float tolerance


@pytest.mark.slow
def test_each_torchrun_process_destroys_its_process_group_before_the_interpreter_ends(tmp_path: Path) -> None:
    # atexit runs its handlers last-registered first: one registered before the group records what is left, each
    # rank in its own file (the two share one stdout)
    script = tmp_path / "group_at_exit.py"
    script.write_text(
        "import atexit, os, pathlib, torch.distributed as dist\n"
        "from bimanualshift.training.distributed import init_distributed\n"
        f"out = pathlib.Path({str(tmp_path)!r})\n"
        "atexit.register(lambda: (out / f'rank{os.environ[\"RANK\"]}').write_text(str(dist.is_initialized())))\n"
        "ctx = init_distributed()\n"
        "ctx.barrier()\n")
    command = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", "2", str(script)]
    done = subprocess.run(command, capture_output=True, text=True, env={**os.environ, "OMP_NUM_THREADS": "1"},
                          timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert [(tmp_path / f"rank{rank}").read_text() for rank in (0, 1)] == ["False", "False"]  # group destroyed
