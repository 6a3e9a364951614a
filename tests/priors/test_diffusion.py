from pathlib import Path

import pytest
import torch

from bimanualshift.configs import PRIOR_SIZES
from bimanualshift.priors import PRIORS, UnimanualPrior
from bimanualshift.priors.diffusion.configuration_diffusion import DiffusionConfig
from bimanualshift.priors.diffusion.modeling_diffusion import DiffusionPrior


def tiny() -> DiffusionPrior:
    torch.manual_seed(0)
    return DiffusionPrior(DiffusionConfig(**PRIOR_SIZES["diffusion"]["debug"]))


def inputs(model: DiffusionPrior, batch: int = 2) -> tuple[torch.Tensor, ...]:
    c = model.config
    g = torch.Generator().manual_seed(1)
    voxels = torch.zeros(batch, 4, c.voxel_size, c.voxel_size, c.voxel_size)
    voxels[:, :, 4:9, 5:10, 2:6] = torch.rand(batch, 4, 5, 5, 4, generator=g)
    voxels[:, 0] = (voxels[:, 0] > 0.3).float()
    return voxels, torch.rand(batch, c.proprio_dim + 1, generator=g), torch.rand(batch, c.text_dim, generator=g)


def actions(batch: int, horizon: int) -> dict[str, torch.Tensor]:
    quat = torch.nn.functional.normalize(torch.randn(batch, horizon, 4, generator=torch.Generator().manual_seed(2)),
                                         dim=-1)
    return {"position": torch.tensor([0.5, 0.0, 0.1]).expand(batch, horizon, 3).clone(), "quat": quat,
            "gripper_open": torch.ones(batch, horizon, dtype=torch.long),
            "ignore_collisions": torch.zeros(batch, horizon, dtype=torch.long)}


def test_registered_by_type() -> None:
    assert PRIORS["diffusion"] is DiffusionPrior
    assert DiffusionConfig().to_dict()["type"] == "diffusion"


def test_loss_has_gradients_and_prediction_is_a_valid_chunk() -> None:
    model = tiny()
    losses = model.compute_loss(inputs(model), actions(2, model.action_horizon), torch.Generator().manual_seed(0))
    losses["total"].backward()
    assert all(p.grad is not None for p in model.parameters() if p.requires_grad)
    pred = model.predict(*inputs(model))
    assert pred.position.shape == (2, 3) and pred.features.shape == (2, model.feature_dim)
    assert pred.chunk.shape == (2, model.config.horizon, 8)
    torch.testing.assert_close(pred.quat.norm(dim=-1), torch.ones(2))
    assert torch.all((pred.gripper_open >= 0) & (pred.gripper_open <= 1))
    assert torch.all(pred.position >= model.action_low[:3]) and torch.all(pred.position <= model.action_high[:3])


def test_action_encoding_round_trip() -> None:
    model = tiny()
    a = actions(3, 2)
    a["position"] = torch.tensor([[0.3, -0.2, 0.0], [0.8, 0.4, 0.3], [0.5, 0.0, -0.1]])[:, None].expand(3, 2, 3)
    decoded = model.decode_actions(model.encode_actions(a["position"], a["quat"], a["gripper_open"],
                                                        a["ignore_collisions"]))
    torch.testing.assert_close(decoded["position"], a["position"], atol=1e-5, rtol=0)
    signs = torch.where(a["quat"][..., 3:] < 0, -1.0, 1.0)
    torch.testing.assert_close(decoded["quat"], a["quat"] * signs, atol=1e-5, rtol=0)
    assert torch.all((decoded["gripper_open"] > 0) == (a["gripper_open"] > 0))


def test_prediction_is_deterministic_and_survives_save_load(tmp_path: Path) -> None:
    model = tiny()
    model.set_normalization(torch.tensor([[0.3, -0.3, 0.0], [0.7, 0.2, 0.2]]))
    model.freeze()
    x = inputs(model)
    first = model.predict(*x)
    assert torch.equal(first.position, model.predict(*x).position)
    model.save_pretrained(tmp_path / "dp")
    loaded = UnimanualPrior.from_pretrained(tmp_path / "dp").freeze()
    torch.testing.assert_close(loaded.action_low, model.action_low, rtol=0, atol=0)  # statistics are saved
    again = loaded.predict(*x)
    for field in ("position", "quat", "gripper_open", "features", "chunk"):
        assert torch.equal(getattr(first, field), getattr(again, field)), field


def test_empty_scene_gives_finite_features() -> None:
    model = tiny()
    voxels, proprio, text = inputs(model)
    out = model.predict(torch.zeros_like(voxels), proprio, text)
    assert torch.isfinite(out.features).all() and torch.isfinite(out.position).all()


def test_wrong_shapes_give_a_clear_error(tmp_path: Path) -> None:
    tiny().save_pretrained(tmp_path / "dp")
    cfg = (tmp_path / "dp" / "config.json").read_text().replace('"point_dim": 32', '"point_dim": 48')
    (tmp_path / "dp" / "config.json").write_text(cfg)
    with pytest.raises(ValueError, match="does not match its config.json"):
        UnimanualPrior.from_pretrained(tmp_path / "dp")


def test_point_tokens_keep_where_the_points_are() -> None:
    from bimanualshift.priors.chunk_actions import PointEncoder

    enc = PointEncoder(voxel_size=8, max_points=16, dim=8, cells=2)
    voxels = torch.zeros(1, 4, 8, 8, 8)
    voxels[0, :, 7, 7, 7] = 1.0  # one occupied voxel, in the last of the 2^3 cells
    tokens, feature = enc(voxels)
    assert tokens.shape == (1, 8, 8) and feature.shape == (1, 8)
    empty = tokens[0, :7] - enc.cell_embedding[:7]
    assert torch.equal(empty, torch.zeros_like(empty))  # empty cells carry only their cell embedding
    torch.testing.assert_close(tokens[0, 7] - enc.cell_embedding[7], feature[0])  # the point's cell holds it
