"""What picks a residual checkpoint on the validation demos (``TrainConfig.select_by``)."""

import pytest
import torch

from bimanualshift.residual.manager import ResidualConfig, ResidualPolicy, manager_inputs
from bimanualshift.residual.skills import SkillBasis
from bimanualshift.training.residual_data import ResidualData
from bimanualshift.training.residual_losses import LossWeights, validation_losses


def residual_moving(translation: list[float], rotation: list[float]) -> ResidualPolicy:
    cfg = ResidualConfig(feature_dim=5, text_dim=8, hidden=16)
    residual = ResidualPolicy(cfg, SkillBasis(cfg.num_skills, 8))
    with torch.no_grad():
        residual.g.bias.copy_(torch.tensor(translation + rotation))
    return residual


def data(n: int, translation: list[float], rotation: list[float]) -> ResidualData:
    g = torch.Generator().manual_seed(0)
    rows = manager_inputs(*(torch.rand(n, w, generator=g) for w in (5, 9, 8, 8, 8)), torch.zeros(n, dtype=torch.long),
                          2)
    return ResidualData(rows, torch.tensor([translation] * n), torch.tensor([rotation] * n))


def test_the_clipped_measure_counts_centimetres_that_the_squared_pose_loss_ignores() -> None:
    # Residual A places every keyframe 4 cm off but turns it 0.1 rad too far; B is exact in position and turns
    # 0.12 rad too far. Squared, 0.1 vs 0.12 rad decides (A wins); clipped, A's 4 cm is 80 % of a miss.
    target = data(6, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    a, b = residual_moving([0.04, 0.0, 0.0], [0.1, 0.0, 0.0]), residual_moving([0.0] * 3, [0.12, 0.0, 0.0])
    weights = LossWeights()
    pose = {n: validation_losses(r, target, weights)["value"] for n, r in (("a", a), ("b", b))}
    clipped = {n: validation_losses(r, target, weights, "clipped_error") for n, r in (("a", a), ("b", b))}
    assert pose["a"] < pose["b"]
    assert clipped["b"]["value"] < clipped["a"]["value"]
    assert clipped["a"]["value"] == pytest.approx(0.04 / 0.05 + 0.1 / 0.35, rel=1e-5)
    assert clipped["a"]["pose_loss"] == pytest.approx(pose["a"])  # the pose loss is still logged
    with pytest.raises(ValueError, match="select_by"):
        validation_losses(a, target, weights, "median")
