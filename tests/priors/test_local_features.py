"""Every prior exposes its features at arm-frame points; the PerAct-style prior also exposes its action logits."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from bimanualshift.priors.base import build_prior


def _inputs(model, seed: int = 0) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:  # noqa: ANN001
    g = torch.Generator().manual_seed(seed)
    s = model.config.voxel_size
    voxels = (torch.rand(2, 4, s, s, s, generator=g) > 0.9).float()
    if model.observation == "points":  # a random coloured cloud filling the arm-frame workspace
        lower, upper = (torch.as_tensor(b, dtype=torch.float32) for b in np.reshape(model.config.bounds, (2, 3)))
        xyz = lower + (upper - lower) * torch.rand(2, model.cloud_points, 3, generator=g)
        voxels = torch.cat([xyz, torch.rand(2, model.cloud_points, 3, generator=g)], -1)
    proprio = torch.rand(2, model.config.proprio_dim + 1, generator=g)
    return voxels, proprio, torch.rand(2, model.config.text_dim, generator=g)


@pytest.mark.parametrize("kind", ["peract", "diffusion", "act", "rvt"])
def test_local_features_are_read_where_asked(kind: str) -> None:
    model = build_prior(kind, "debug").freeze()
    voxels, proprio, text = _inputs(model)
    lower, upper = np.reshape(model.config.bounds, (2, 3))
    near, far = lower + 0.1 * (upper - lower), lower + 0.9 * (upper - lower)
    with torch.no_grad():
        a = model.local_features(voxels, proprio, text, torch.as_tensor(np.stack([near, near]), dtype=torch.float32))
        b = model.local_features(voxels, proprio, text, torch.as_tensor(np.stack([near, far]), dtype=torch.float32))
    assert a.shape == (2, model.local_feature_dim) and model.local_feature_dim > 0
    assert torch.equal(a[0], b[0])  # the same point reads the same features
    assert not torch.allclose(b[0], b[1])  # two places of the scene differ


def test_peract_logits_are_the_distribution_its_action_decodes() -> None:
    model = build_prior("peract", "debug").freeze()
    out = model.predict(*_inputs(model))
    assert out.logits is not None and set(out.logits) == {"translation", "rotation", "gripper", "collision"}
    s = model.config.voxel_size
    index = np.stack(np.unravel_index(out.logits["translation"].argmax(-1).numpy(), (s, s, s)), axis=-1)
    assert np.allclose(model.grid.index_to_point(index), out.position.numpy(), atol=1e-6)
    assert torch.allclose(out.logits["gripper"].softmax(-1)[:, 1], out.gripper_open)
    assert build_prior("diffusion", "debug").freeze().predict(*_inputs(model)).logits is None


def test_the_subvoxel_offset_learns_where_inside_its_voxel_the_target_lies() -> None:
    """One occupied voxel, the target a fixed fraction of a voxel off its centre: the voxel-centre decoding misses
    by that fraction, the offset head learns it."""
    from bimanualshift.training.optim import make_optimizer

    torch.manual_seed(0)
    model = build_prior("peract", "debug", {"subvoxel_offset": True})
    s, n = model.config.voxel_size, 8
    g = torch.Generator().manual_seed(1)
    index = torch.randint(2, s - 2, (n, 3), generator=g)
    voxels = torch.zeros(n, 4, s, s, s)
    voxels[torch.arange(n), 0, index[:, 0], index[:, 1], index[:, 2]] = 1.0
    shift = torch.tensor([0.3, -0.25, 0.2])  # voxels
    centre = torch.as_tensor(model.grid.index_to_point(index.numpy()), dtype=torch.float32)
    target = centre + shift * torch.as_tensor(model.grid.voxel_size)
    actions = {"position": target[:, None], "quat": torch.tensor([[[0.0, 0.0, 0.0, 1.0]]]).expand(n, 1, 4),
               "gripper_open": torch.ones(n, 1), "ignore_collisions": torch.ones(n, 1)}
    proprio, text = torch.zeros(n, model.config.proprio_dim + 1), torch.zeros(n, model.config.text_dim)
    optimiser = make_optimizer("adamw", model.parameters(), lr=3e-3)
    for _ in range(150):
        loss = model.compute_loss((voxels, proprio, text), actions)
        optimiser.zero_grad()
        loss["total"].backward()
        optimiser.step()
    out = model.freeze().predict(voxels, proprio, text)
    hit = out.logits["translation"].argmax(-1) == torch.as_tensor((index[:, 0] * s + index[:, 1]) * s + index[:, 2])
    assert hit.all()  # the right voxel ...
    error = (out.position - target).norm(dim=-1)
    centre_error = (centre - target).norm(dim=-1)
    assert float(error.max()) < 0.3 * float(centre_error.min())  # ... and the right place inside it


@pytest.mark.parametrize("kind", ["peract", "diffusion", "act", "rvt"])
def test_proposal_features_are_read_at_the_prior_own_proposal(kind: str) -> None:
    """The Manager's arm-specific visual input: the prior's features where it points (and around it)."""
    model = build_prior(kind, "debug").freeze()
    inputs = _inputs(model)
    with torch.no_grad():
        out = model.predict(*inputs)
        proposal = model.proposal_features(*inputs, out)
        at_point = model.local_features(*inputs, out.position)
    assert proposal.shape == (2, model.proposal_feature_dim) and model.proposal_feature_dim > 0
    if kind == "peract":  # the maps at the peak, then their mean one voxel around it
        torch.testing.assert_close(proposal[:, : model.local_feature_dim], at_point)
    elif kind == "rvt":  # the fine stage's per-view maps at the final position, then the coarse stage's there
        torch.testing.assert_close(proposal[:, model.local_feature_dim:], at_point)
    else:  # no maps kept while predicting: the local features at the proposal, one more pass
        assert out.proposal_features is None
        torch.testing.assert_close(proposal, at_point)
