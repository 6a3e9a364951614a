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
    proprio = torch.rand(2, model.config.proprio_dim + 1, generator=g)
    return voxels, proprio, torch.rand(2, model.config.text_dim, generator=g)


@pytest.mark.parametrize("kind", ["peract", "diffusion", "act"])
def test_local_features_are_read_where_asked(kind: str) -> None:
    model = build_prior(kind, "debug").freeze()
    voxels, proprio, text = _inputs(model)
    lower, upper = np.asarray(model.grid.lower), np.asarray(model.grid.upper)
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
