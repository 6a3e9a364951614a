"""Sharing on the hub, offline: what `push` stages is what `pull` loads, bit for bit, through the shared cache
(populated here with the staged files, as a download leaves them). No upload to the real hub runs in the tests:
the push stops where the client needs a network, with a message that says so."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest
import torch

from bimanualshift.cli import main
from bimanualshift.configs import prior_model_config
from bimanualshift.data.episode import list_episodes
from bimanualshift.encoders.text import default_text_encoder
from bimanualshift.evaluation.hub import Staged, pull, push, stage, upload_plan
from bimanualshift.memory.bank import MemoryBank, MemoryEntry, memory_key
from bimanualshift.methods.bimanualshift import MEMORY_FILE, load_bimanualshift, save_residual
from bimanualshift.priors import PRIORS, UnimanualPrior
from bimanualshift.residual.manager import ResidualConfig, ResidualPolicy
from bimanualshift.residual.skills import SkillBasis
from tests.utils.test_hub_refs import populate_cache


@pytest.fixture
def offline_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("HF_HUB_CACHE", str(tmp_path / "hub"))
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    return tmp_path / "hub"


def _prior(folder: Path) -> Path:
    cls = PRIORS["peract"]
    torch.manual_seed(0)
    return cls(cls.config_class(**prior_model_config("peract", "debug"))).save_pretrained(folder)


def _checkpoint(folder: Path, prior: Path) -> Path:
    config = ResidualConfig(hidden=16, feature_dim=8, text_dim=384, num_skills=4, reference_dim=8)
    torch.manual_seed(1)
    residual = ResidualPolicy(config, SkillBasis(4, 384))
    bank = MemoryBank(6)
    bank.add(memory_key(torch.ones(3).numpy(), torch.arange(1, 4).float().numpy()), torch.zeros(2, 2, 4).numpy(),
             MemoryEntry("push_two_buttons", "push both buttons", "demo", 0))
    save_residual(folder / "best", residual, {"prior": str(prior), "task": "push_two_buttons", "demos": 2,
                                              "text_encoder": "minilm", "trained_steps": 10}, bank)
    (folder / "train_config.json").write_text(json.dumps({"dataset": {"data": "data/x/train", "demos": 2}}))
    return folder / "best"


def _as_downloaded(staged: Staged, cache: Path, repo_id: str, revision: str = "main") -> None:
    files = {name: (staged.folder / name).read_bytes() for name in staged.files}
    populate_cache(cache, repo_id, files, staged.repo_type, revision)


def test_prior_pushed_then_pulled_by_name_loads_identical_weights(tmp_path: Path, offline_cache: Path) -> None:
    source = _prior(tmp_path / "prior")
    staged = stage(source, tmp_path / "staged", repo_id="lab/tiny-prior")
    assert staged.kind == "prior" and staged.files == ["README.md", "config.json", "model.safetensors"]
    card = (staged.folder / "README.md").read_text()
    assert card.startswith("---\nlibrary_name: bimanualshift") and "--prior hf://lab/tiny-prior" in card
    plan = upload_plan(staged)
    weights = next(f for f in plan if f["path"] == "model.safetensors")
    assert weights["sha256"] == hashlib.sha256((source / "model.safetensors").read_bytes()).hexdigest()

    _as_downloaded(staged, offline_cache, "lab/tiny-prior", revision="v1")
    folder, kind, _ = pull("lab/tiny-prior@v1")
    assert kind == "prior"
    original, pulled = UnimanualPrior.from_pretrained(source), UnimanualPrior.from_pretrained("hf://lab/tiny-prior@v1")
    for key, value in original.state_dict().items():
        assert torch.equal(value, pulled.state_dict()[key]), key
    assert (folder / "model.safetensors").read_bytes() == (source / "model.safetensors").read_bytes()


def test_checkpoint_carries_its_memory_bank_and_prior(tmp_path: Path, offline_cache: Path) -> None:
    best = _checkpoint(tmp_path / "run", _prior(tmp_path / "prior"))
    results = tmp_path / "summary.json"
    results.write_text(json.dumps({"command": "bimanualshift bench --tasks push_two_buttons", "commit": "abc123",
                                   "seeds": {"test": [200000, 200029]}, "rows": [
                                       {"task": "push_two_buttons", "method": "bimanualshift", "success": 0.9,
                                        "ci95": [0.74, 0.97], "episodes": 30},
                                       {"task": "lift_ball", "method": "bimanualshift", "success": 0.5,
                                        "ci95": [0.3, 0.7], "episodes": 30}]}))
    staged = stage(best, tmp_path / "staged", results, "bimanualshift", "lab/bs-buttons")
    assert {MEMORY_FILE, "train_config.json", "prior/model.safetensors"} <= set(staged.files)
    card = (staged.folder / "README.md").read_text()
    # the rows of this checkpoint's task only, with the interval and the command behind them
    assert "| push_two_buttons | 90 % (74–97) | 30 |" in card and "lift_ball" not in card
    assert "bimanualshift bench --tasks push_two_buttons" in card and "seeds 200000–200029 (test)" in card
    assert json.loads((staged.folder / "config.json").read_text())["prior"] == "prior"

    _as_downloaded(staged, offline_cache, "lab/bs-buttons")
    _, kind, _ = pull("hf://lab/bs-buttons")
    assert kind == "checkpoint"
    encoder = default_text_encoder()
    original, pulled = load_bimanualshift(best, encoder), load_bimanualshift("hf://lab/bs-buttons", encoder)
    for key, value in original.residual.state_dict().items():
        assert torch.equal(value, pulled.residual.state_dict()[key]), key
    for key, value in original.prior_step.prior.state_dict().items():
        assert torch.equal(value, pulled.prior_step.prior.state_dict()[key]), key
    assert len(pulled.memory) == len(original.memory) == 1


def test_dataset_is_read_through_data_flag(tmp_path: Path, offline_cache: Path) -> None:
    data = tmp_path / "demos"
    for seed in (0, 1):
        (data / "push_two_buttons" / f"episode_{seed:06d}.h5").parent.mkdir(parents=True, exist_ok=True)
        (data / "push_two_buttons" / f"episode_{seed:06d}.h5").write_bytes(bytes([seed]) * 10)
    staged = stage(data, tmp_path / "staged", repo_id="lab/demos")
    assert staged.repo_type == "dataset"
    _as_downloaded(staged, offline_cache, "lab/demos")
    paths = list_episodes("hf://datasets/lab/demos", "push_two_buttons")
    assert [p.read_bytes() for p in paths] == [b"\x00" * 10, b"\x01" * 10]


def test_refuses_pickle_and_unknown_folders(tmp_path: Path) -> None:
    data = tmp_path / "demos"
    (data / "t").mkdir(parents=True)
    (data / "t" / "episode_000000.h5").write_bytes(b"x")
    (data / "t" / "stats.pkl").write_bytes(b"x")
    with pytest.raises(ValueError, match=r"pickle loader would read \(t/stats.pkl\)"):
        stage(data, tmp_path / "staged")
    (tmp_path / "empty").mkdir()
    with pytest.raises(FileNotFoundError, match="holds no config.json"):
        stage(tmp_path / "empty", tmp_path / "staged")


def test_push_stops_before_the_network_when_offline(tmp_path: Path, offline_cache: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    source = _prior(tmp_path / "prior")
    staged = stage(source, tmp_path / "staged")
    with pytest.raises(ConnectionError, match="HF_HUB_OFFLINE=1 is set, so nothing can be uploaded"):
        push(staged, "lab/tiny-prior")
    main(["push", str(source), "lab/tiny-prior", "--dry-run", "--stage", str(tmp_path / "kept")])
    out = capsys.readouterr().out
    assert "prior" in out and "dry run: nothing was uploaded" in out and (tmp_path / "kept" / "README.md").is_file()
    with pytest.raises(SystemExit, match="HF_HUB_OFFLINE=1 is set"):
        main(["push", str(source), "lab/tiny-prior"])
    with pytest.raises(SystemExit, match="not in the local cache"):
        main(["pull", "lab/never-pulled"])
