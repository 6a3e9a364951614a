from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file, save_file

from bimanualshift.configs import PRIOR_MODELS
from bimanualshift.priors import PRIORS, UnimanualPrior
from bimanualshift.priors.peract.configuration_peract import PerActConfig
from bimanualshift.priors.peract.modeling_peract import PerActPrior


def tiny() -> PerActPrior:
    torch.manual_seed(0)
    return PerActPrior(PerActConfig(**PRIOR_MODELS["debug"]))


def inputs(model: PerActPrior, batch: int = 2) -> tuple[torch.Tensor, ...]:
    s, c = model.config.voxel_size, model.config
    g = torch.Generator().manual_seed(1)
    return (torch.rand(batch, 4, s, s, s, generator=g), torch.rand(batch, c.proprio_dim + 1, generator=g),
            torch.rand(batch, c.text_dim, generator=g))


def test_registered_by_type() -> None:
    assert PRIORS["peract"] is PerActPrior
    assert PerActConfig().to_dict()["type"] == "peract"


def test_shapes_and_gradients() -> None:
    model = tiny()
    out = model(*inputs(model))
    s = model.config.voxel_size
    assert out["translation"].shape == (2, s**3)
    assert out["rotation"].shape == (2, 3, model.config.rotation_bins)
    assert out["features"].shape == (2, model.feature_dim)
    target = {"translation_index": torch.tensor([0, s**3 - 1]), "rotation_bins": torch.zeros(2, 3, dtype=torch.long),
              "gripper_open": torch.tensor([0, 1]), "ignore_collisions": torch.tensor([1, 0])}
    model.loss(out, target)["total"].backward()
    assert all(p.grad is not None for p in model.parameters() if p.requires_grad)
    pred = model.predict(*inputs(model))
    lower, upper = model.grid.lower, model.grid.upper
    assert torch.all(pred.position >= torch.as_tensor(lower)) and torch.all(pred.position <= torch.as_tensor(upper))
    torch.testing.assert_close(pred.quat.norm(dim=-1), torch.ones(2))


def test_save_load_gives_identical_outputs(tmp_path: Path) -> None:
    model = tiny().eval()
    model.save_pretrained(tmp_path / "ckpt")
    loaded = UnimanualPrior.from_pretrained(tmp_path / "ckpt").eval()
    x = inputs(model)
    for key, value in model(*x).items():
        assert torch.equal(value, loaded(*x)[key]), key


def test_bad_checkpoints_give_clear_errors(tmp_path: Path) -> None:
    model = tiny()
    model.save_pretrained(tmp_path / "ckpt")
    (tmp_path / "empty").mkdir()
    with pytest.raises(FileNotFoundError, match="no config.json"):
        UnimanualPrior.from_pretrained(tmp_path / "empty")
    state = load_file(str(tmp_path / "ckpt" / "model.safetensors"))
    state["pos_embed"] = torch.zeros(1, 3, 3)
    save_file(state, str(tmp_path / "ckpt" / "model.safetensors"))
    with pytest.raises(ValueError, match="pos_embed: checkpoint \\(1, 3, 3\\)"):
        UnimanualPrior.from_pretrained(tmp_path / "ckpt")


def test_freeze_keeps_eval_mode_and_no_grad() -> None:
    model = tiny().freeze()
    wrapper = torch.nn.ModuleDict({"prior": model, "head": torch.nn.Linear(2, 2)})
    wrapper.train()
    assert not model.training
    assert not any(p.requires_grad for p in model.parameters())
