"""Shipping a prior: files copied, a results block added once, size limit and broken sources refused."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from bimanualshift.configs import prior_model_config
from bimanualshift.priors import PRIORS, UnimanualPrior
from bimanualshift.priors.shipping import ship_prior


def _pretrained(folder: Path) -> Path:
    cls = PRIORS["peract"]
    torch.manual_seed(0)
    cls(cls.config_class(**prior_model_config("peract", "debug"))).save_pretrained(folder)
    (folder / "README.md").write_text("# card\n")
    return folder


def test_ships_loadable_copy_with_results_block(tmp_path: Path) -> None:
    source = _pretrained(tmp_path / "best")
    target = ship_prior(source, "tiny", destination=tmp_path / "checkpoints")
    assert (target / "model.safetensors").read_bytes() == (source / "model.safetensors").read_bytes()
    card = (target / "README.md").read_text()
    assert card.startswith("# card") and card.count("<!-- results:priors -->") == 1
    ship_prior(target, "tiny2", destination=tmp_path / "checkpoints")  # re-shipping keeps one block
    assert (tmp_path / "checkpoints" / "tiny2" / "README.md").read_text().count("<!-- results:priors -->") == 1
    UnimanualPrior.from_pretrained(target)


def test_refuses_oversized_and_incomplete_sources(tmp_path: Path) -> None:
    source = _pretrained(tmp_path / "best")
    with pytest.raises(ValueError, match="must stay under"):
        ship_prior(source, "tiny", destination=tmp_path / "c", max_mb=0.001)
    (source / "README.md").unlink()
    with pytest.raises(FileNotFoundError, match="lacks \\['README.md'\\]"):
        ship_prior(source, "tiny", destination=tmp_path / "c")
    assert not (tmp_path / "c").exists()


def test_card_names_the_result_file_it_is_filled_from(tmp_path: Path) -> None:
    target = ship_prior(_pretrained(tmp_path / "best"), "tiny", destination=tmp_path / "c", results="priors_ur5e")
    card = (target / "README.md").read_text()
    assert "<!-- results:priors_ur5e -->" in card and "<!-- results:priors -->" not in card
    assert "results/priors_ur5e.json" in card
