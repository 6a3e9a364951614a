"""The residual branch's checkpoint: ``model.safetensors`` (Manager, Z, G and their input statistics) and
``config.json`` (``type: bimanualshift``, the ``ResidualConfig`` under ``residual``, and whatever the trainer adds:
the prior, the projection switches, the text encoder's spec). Loading checks both files and names what is wrong."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import Any

from safetensors.torch import save_file

from bimanualshift.residual.manager import ResidualConfig, ResidualPolicy
from bimanualshift.residual.skills import SkillBasis
from bimanualshift.utils.config_files import CheckpointError, config_from_dict, load_checked_weights, read_json_file
from bimanualshift.utils.hub import resolve_local
from bimanualshift.utils.io import atomic_write_json, atomic_writer

WEIGHTS_FILE, CONFIG_FILE = "model.safetensors", "config.json"


def save_residual_checkpoint(directory: str | Path, residual: ResidualPolicy, extra: dict[str, Any]) -> Path:
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    with atomic_writer(directory / WEIGHTS_FILE) as tmp:
        save_file({k: v.detach().contiguous() for k, v in residual.state_dict().items()}, str(tmp))
    atomic_write_json(directory / CONFIG_FILE, {"type": "bimanualshift", "residual": asdict(residual.config),
                                                **extra})
    return directory


def read_residual_config(directory: str | Path) -> tuple[dict[str, Any], ResidualConfig]:
    """The checkpoint's whole config.json and its checked ``ResidualConfig``."""
    directory = resolve_local(directory)
    path = directory / CONFIG_FILE
    if not path.is_file():
        raise FileNotFoundError(f"no BimanualShift checkpoint at {directory} ({CONFIG_FILE} missing); train one with "
                                "`bimanualshift train`")
    raw = read_json_file(path, "BimanualShift checkpoint")
    if not isinstance(raw.get("residual"), dict):
        raise CheckpointError(f"{path} has no 'residual' object: it is not a BimanualShift checkpoint (a prior's "
                              "folder goes to --prior, a trained BimanualShift's best/ to --checkpoint)")
    return raw, config_from_dict(ResidualConfig, raw["residual"], f"{path} (residual)", ignore_unknown=False)


def load_residual_checkpoint(directory: str | Path, text_dim: int) -> tuple[dict[str, Any], ResidualPolicy]:
    """(config.json, the residual with its weights); ``text_dim`` is the width of the residual's text encoder."""
    directory = resolve_local(directory)
    raw, config = read_residual_config(directory)
    residual = ResidualPolicy(config, SkillBasis(config.num_skills, text_dim))
    weights = Path(directory) / WEIGHTS_FILE
    if not weights.is_file():
        raise FileNotFoundError(f"{directory} has {CONFIG_FILE} but no {WEIGHTS_FILE}; copy the whole checkpoint "
                                "folder")
    load_checked_weights(residual, weights, f"copy both files from the same run (the residual was built for a "
                                           f"{text_dim}-wide text encoder: load it with the one its config names)")
    return raw, residual
