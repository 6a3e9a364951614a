"""ACT: CVAE loss with gradients everywhere, deterministic inference (z = 0), save/load, learning a chunk."""

from pathlib import Path

import torch

from bimanualshift.configs import PRIOR_SIZES
from bimanualshift.priors import PRIORS, UnimanualPrior
from bimanualshift.priors.act.configuration_act import ACTConfig
from bimanualshift.priors.act.modeling_act import ACTPolicy
from tests.priors.test_diffusion import actions, inputs


def tiny() -> ACTPolicy:
    torch.manual_seed(0)
    return ACTPolicy(ACTConfig(**PRIOR_SIZES["act"]["debug"]))


def test_registered_by_type() -> None:
    assert PRIORS["act"] is ACTPolicy and ACTConfig().to_dict()["type"] == "act"


def test_loss_has_gradients_and_kl_term() -> None:
    model = tiny()
    losses = model.compute_loss(inputs(model), actions(2, model.action_horizon), torch.Generator().manual_seed(0))
    losses["total"].backward()
    missing = [n for n, p in model.named_parameters() if p.requires_grad and p.grad is None]
    assert not missing, missing  # the style encoder learns through the KL and the latent's use
    torch.testing.assert_close(losses["total"], losses["l1"] + model.config.kl_weight * losses["kl"])
    assert losses["kl"] >= 0


def test_prediction_is_deterministic_valid_and_survives_save_load(tmp_path: Path) -> None:
    model = tiny()
    model.set_normalization(torch.tensor([[0.3, -0.3, 0.0], [0.7, 0.2, 0.2]]))
    model.freeze()
    x = inputs(model)
    first = model.predict(*x)
    assert first.position.shape == (2, 3) and first.chunk.shape == (2, model.config.horizon, 8)
    torch.testing.assert_close(first.quat.norm(dim=-1), torch.ones(2))
    assert torch.all(first.position >= model.action_low[:3]) and torch.all(first.position <= model.action_high[:3])
    model.save_pretrained(tmp_path / "act")
    again = UnimanualPrior.from_pretrained(tmp_path / "act").freeze().predict(*x)
    for field in ("position", "quat", "gripper_open", "features", "chunk"):
        assert torch.equal(getattr(first, field), getattr(again, field)), field


def test_fits_one_chunk() -> None:
    model = tiny()
    model.set_normalization(torch.tensor([[0.3, -0.3, 0.0], [0.7, 0.2, 0.2]]))
    x, target = inputs(model), actions(2, model.action_horizon)
    target["position"] = torch.tensor([[0.6, 0.1, 0.15], [0.4, -0.1, 0.05]])[:, None].expand(2, 2, 3).clone()
    optimiser = torch.optim.AdamW(model.parameters(), lr=3e-3)
    gen = torch.Generator().manual_seed(0)
    for _ in range(150):
        optimiser.zero_grad()
        model.compute_loss(x, target, gen)["total"].backward()
        optimiser.step()
    error = (model.predict(*x).position - target["position"][:, 0]).norm(dim=-1)
    assert torch.all(error < 0.03), error
