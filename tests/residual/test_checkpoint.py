"""The residual's checkpoint round-trips and refuses damaged files with a message that names them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from bimanualshift.residual.checkpoint import load_residual_checkpoint, save_residual_checkpoint
from bimanualshift.residual.manager import ResidualConfig, ResidualPolicy
from bimanualshift.residual.skills import SkillBasis
from bimanualshift.utils.config_files import CheckpointError


def _saved(tmp_path: Path) -> tuple[Path, ResidualPolicy]:
    config = ResidualConfig(hidden=16, feature_dim=8, text_dim=12, num_skills=4)
    residual = ResidualPolicy(config, SkillBasis(4, 12))
    return save_residual_checkpoint(tmp_path / "ckpt", residual, {"prior": "peract_suite"}), residual


def test_round_trip(tmp_path: Path) -> None:
    directory, residual = _saved(tmp_path)
    raw, loaded = load_residual_checkpoint(directory, 12)
    assert raw["prior"] == "peract_suite" and loaded.config == residual.config
    for key, value in residual.state_dict().items():
        assert torch.equal(value, loaded.state_dict()[key]), key


def test_damaged_files_are_named(tmp_path: Path) -> None:
    directory, _ = _saved(tmp_path)
    path = directory / "config.json"
    raw = json.loads(path.read_text())
    path.write_text(json.dumps({**raw, "residual": {**raw["residual"], "hidden": "wide"}}))
    with pytest.raises(CheckpointError, match=r"config.json \(residual\): field 'hidden' is 'wide'"):
        load_residual_checkpoint(directory, 12)
    path.write_text(json.dumps(raw))
    with pytest.raises(CheckpointError, match="does not match its config.json"):
        load_residual_checkpoint(directory, 7)  # a text encoder of another width
    (directory / "model.safetensors").write_bytes(b"{}")
    with pytest.raises(CheckpointError, match="truncated or corrupt"):
        load_residual_checkpoint(directory, 12)
    path.write_text(json.dumps({"type": "peract", "dim": 32}))
    with pytest.raises(CheckpointError, match="not a BimanualShift checkpoint"):
        load_residual_checkpoint(directory, 12)
