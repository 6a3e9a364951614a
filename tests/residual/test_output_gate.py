import pytest
import torch

from bimanualshift.residual.manager import ResidualConfig, ResidualPolicy, manager_inputs
from bimanualshift.residual.output_gate import choose_output_scale, reset_output_scale
from bimanualshift.residual.skills import SkillBasis


def constant_residual(translation: list[float], rotation: list[float], gate: bool = True) -> ResidualPolicy:
    """A residual whose output is the same (translation, rotation) for every input (G's bias, zero weights)."""
    cfg = ResidualConfig(feature_dim=5, text_dim=8, hidden=16, output_gate=gate)
    residual = ResidualPolicy(cfg, SkillBasis(cfg.num_skills, 8))
    with torch.no_grad():
        residual.g.bias.copy_(torch.tensor(translation + rotation))
    return residual


def inputs(batch: int) -> torch.Tensor:
    g = torch.Generator().manual_seed(0)
    return manager_inputs(torch.rand(batch, 5, generator=g), torch.rand(batch, 9, generator=g),
                          torch.rand(batch, 8, generator=g), torch.rand(batch, 8, generator=g),
                          torch.rand(batch, 8, generator=g), torch.zeros(batch, dtype=torch.long), 2)


def test_a_residual_that_matches_the_targets_is_kept_whole() -> None:
    residual = constant_residual([0.1, 0.0, 0.0], [0.0, 0.0, 0.2])
    n = 20
    chosen = choose_output_scale(residual, inputs(n), torch.tensor([[0.1, 0.0, 0.0]] * n),
                                 torch.tensor([[0.0, 0.0, 0.2]] * n))
    assert chosen["translation_scale"] == 1.0 and chosen["rotation_scale"] == 1.0
    assert chosen["translation_clipped_error"] == pytest.approx(0.0, abs=1e-6)
    assert chosen["translation_clipped_error_prior"] == pytest.approx(0.05)  # 10 cm misses clip at 5 cm


def test_a_residual_that_moves_well_placed_keyframes_is_turned_off_even_if_it_fixes_far_misses() -> None:
    # 18 of 20 keyframes the prior already places exactly; 2 it misses by 50 cm. The residual moves every
    # keyframe by 2 cm toward the misses: it lowers the squared error but spoils 18 keyframes.
    residual = constant_residual([0.02, 0.0, 0.0], [0.0, 0.0, 0.0])
    target = torch.zeros(20, 3)
    target[:2, 0] = 0.5
    assert ((target - residual(inputs(20))["translation"]) ** 2).sum(-1).mean() < (target ** 2).sum(-1).mean()
    chosen = choose_output_scale(residual, inputs(20), target, torch.zeros(20, 3))
    assert chosen["translation_scale"] == 0.0
    out = residual(inputs(20))
    assert torch.equal(out["translation"], torch.zeros(20, 3))  # the factor is applied in forward
    reset_output_scale(residual)
    assert torch.allclose(residual(inputs(20))["translation"][:, 0], torch.full((20,), 0.02))


def test_translation_and_rotation_are_chosen_separately_and_survive_the_state_dict() -> None:
    residual = constant_residual([0.04, 0.0, 0.0], [0.0, 0.3, 0.0])
    n = 10
    chosen = choose_output_scale(residual, inputs(n), torch.tensor([[0.02, 0.0, 0.0]] * n), torch.zeros(n, 3))
    assert chosen["translation_scale"] == 0.5 and chosen["rotation_scale"] == 0.0
    copy = constant_residual([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    copy.load_state_dict(residual.state_dict())
    assert torch.equal(copy.output_scale, torch.tensor([0.5, 0.0]))


def test_a_residual_without_the_gate_or_without_data_is_refused() -> None:
    with pytest.raises(ValueError, match="output_gate=False"):
        choose_output_scale(constant_residual([0, 0, 0], [0, 0, 0], gate=False), inputs(2), torch.zeros(2, 3),
                            torch.zeros(2, 3))
    with pytest.raises(ValueError, match="no validation samples"):
        choose_output_scale(constant_residual([0, 0, 0], [0, 0, 0]), inputs(2)[:0], torch.zeros(0, 3),
                            torch.zeros(0, 3))


def test_per_keyframe_factors_keep_the_residual_where_it_helps_and_drop_it_where_it_hurts() -> None:
    from bimanualshift.residual.manager import manager_input_rows

    cfg = ResidualConfig(feature_dim=5, text_dim=8, hidden=16, output_gate=True, phase_dim=8, gate_per_keyframe=True)
    residual = ResidualPolicy(cfg, SkillBasis(cfg.num_skills, 8))
    with torch.no_grad():
        residual.g.bias.copy_(torch.tensor([0.03, 0.0, 0.0, 0.0, 0.0, 0.0]))  # 3 cm along x everywhere
    n = 12
    g = torch.Generator().manual_seed(0)
    parts = [torch.rand(n, w, generator=g) for w in (5, 9, 8, 8, 8)]
    keyframe = torch.tensor([0, 1, 2] * 4)
    arm = torch.tensor([0] * 6 + [1] * 6)  # both arms' keyframe k share slot k
    rows = manager_input_rows(cfg, *parts, arm, keyframe)
    target = torch.zeros(n, 3)
    target[keyframe == 0, 0] = 0.03  # keyframe 0: the prior misses by 3 cm, the residual fixes it
    target[keyframe == 2, 0] = 0.015  # keyframe 2: half of it; keyframe 1: the prior is exact
    chosen = choose_output_scale(residual, rows, target, torch.zeros(n, 3))
    assert chosen["per_keyframe"]["keyframes"] == [0, 1, 2]
    assert chosen["per_keyframe"]["translation_scale"] == [1.0, 0.0, 0.5]
    assert chosen["per_keyframe"]["translation_clipped_error"] == pytest.approx(0.0, abs=1e-6)
    out = residual(rows)["translation"][:, 0]
    torch.testing.assert_close(out, target[:, 0])  # each row gets its keyframe's factor in forward
    # a slot no validation sample reached keeps the factor chosen on all samples (here 0.5)
    assert residual.output_scale[3].tolist() == [chosen["translation_scale"], chosen["rotation_scale"]]
    with pytest.raises(ValueError, match="gate_per_keyframe"):
        ResidualPolicy(ResidualConfig(feature_dim=5, text_dim=8, output_gate=True, gate_per_keyframe=True),
                       SkillBasis(16, 8))
