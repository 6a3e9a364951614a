import numpy as np
import pytest
import torch

from bimanualshift.residual.manager import ResidualConfig, ResidualPolicy, manager_inputs
from bimanualshift.residual.skills import DEFAULT_SKILL_VERBS, SkillBasis


class FakeEncoder:
    dim = 8

    def encode(self, texts: list[str]) -> np.ndarray:
        return np.stack([np.full(8, len(t), dtype=np.float32) for t in texts])


def tiny(structured: bool = True) -> ResidualPolicy:
    cfg = ResidualConfig(feature_dim=5, text_dim=8, hidden=16, structured=structured)
    return ResidualPolicy(cfg, SkillBasis.from_verbs(FakeEncoder()))


def inputs(batch: int = 3) -> torch.Tensor:
    g = torch.Generator().manual_seed(0)
    return manager_inputs(torch.rand(batch, 5, generator=g), torch.rand(batch, 9, generator=g),
                          torch.rand(batch, 8, generator=g), torch.rand(batch, 8, generator=g),
                          torch.rand(batch, 8, generator=g), torch.tensor([0, 1, 0])[:batch], 2)


def test_basis_is_initialised_from_the_verbs() -> None:
    basis = SkillBasis.from_verbs(FakeEncoder())
    assert basis.z.shape == (16, 8) and len(DEFAULT_SKILL_VERBS) == 16
    assert basis.z.requires_grad
    assert torch.equal(basis.z[0], torch.full((8,), float(len("reach"))))


def test_weights_sum_to_one_and_v_follows_eq7() -> None:
    policy = tiny()
    x = inputs()
    out = policy(x)
    torch.testing.assert_close(out["weights"].sum(-1), torch.ones(3))
    weights, h = policy.manager(x)
    torch.testing.assert_close(out["v"], weights @ policy.basis.z + h)


def test_hand_computed_v() -> None:
    basis = SkillBasis(2, 2)
    with torch.no_grad():
        basis.z.copy_(torch.tensor([[1.0, 0.0], [0.0, 2.0]]))
    v = basis.combine(torch.tensor([[0.25, 0.75]]), torch.tensor([[0.5, -0.5]]))
    torch.testing.assert_close(v, torch.tensor([[0.75, 1.0]]))


def test_zero_initialised_g_leaves_the_prior_action_unchanged() -> None:
    out = tiny()(inputs())
    assert torch.count_nonzero(out["translation"]) == 0 and torch.count_nonzero(out["rotation"]) == 0


def test_unstructured_ablation_skips_the_basis() -> None:
    policy = tiny(structured=False)
    x = inputs()
    _, h = policy.manager(x)
    torch.testing.assert_close(policy(x)["v"], h)


def test_input_normalisation_standardises_and_round_trips_through_the_state_dict() -> None:
    from bimanualshift.residual.manager import INPUT_STD_FLOOR

    cfg = ResidualConfig(feature_dim=5, text_dim=8, hidden=16, normalise_inputs=True)
    policy = ResidualPolicy(cfg, SkillBasis.from_verbs(FakeEncoder()))
    x = inputs() * 10 + 3
    policy.fit_normalisation(x)
    torch.testing.assert_close(policy.input_mean, x.mean(0))
    assert torch.all(policy.input_std >= INPUT_STD_FLOOR)
    copy = ResidualPolicy(cfg, SkillBasis.from_verbs(FakeEncoder()))
    copy.load_state_dict(policy.state_dict())  # the statistics travel with the weights
    torch.testing.assert_close(copy.input_std, policy.input_std)
    seen = []
    copy.manager.register_forward_hook(lambda module, args, out: seen.append(args[0]))
    copy(x)
    torch.testing.assert_close(seen[0].mean(0), torch.zeros(x.shape[1]), atol=1e-5, rtol=0)
    try:
        tiny().fit_normalisation(x)
    except ValueError as err:
        assert "normalise_inputs=False" in str(err)
    else:
        raise AssertionError("a residual without normalisation must refuse statistics")


def test_phase_one_hot_gives_each_arm_its_slots_and_clamps_late_keyframes() -> None:
    from bimanualshift.residual.manager import phase_one_hot

    four = ResidualConfig(phase_dim=4)
    out = phase_one_hot(four, torch.tensor([0, 1, 7]), torch.tensor([0, 1, 0]))
    torch.testing.assert_close(out, torch.tensor([[1.0, 0, 0, 0], [0, 0, 0, 1], [0, 1, 0, 0]]))
    # the numpy and torch paths of the slot clamp agree, and the one-hot's arm and slot read back
    np.testing.assert_array_equal(four.phase_slot(np.array([0, 1, 7])), [0, 1, 1])
    from bimanualshift.residual.manager import arm_and_slot
    arm, slot = arm_and_slot(four, torch.cat([torch.zeros(3, four.layout()["phase"].start), out], dim=1))
    assert arm.tolist() == [0, 1, 0] and slot.tolist() == [0, 1, 1]
    with pytest.raises(ValueError, match="does not split"):
        phase_one_hot(ResidualConfig(phase_dim=5), torch.tensor([0]), torch.tensor([0]))
    cfg = ResidualConfig(feature_dim=5, text_dim=8, hidden=16, goal_dim=10, phase_dim=4, geometric_skip=True,
                         read_prior_features=False)
    policy = ResidualPolicy(cfg, SkillBasis.from_verbs(FakeEncoder()))
    g = torch.Generator().manual_seed(1)
    row = manager_inputs(torch.rand(3, 5, generator=g), torch.rand(3, 9, generator=g), torch.rand(3, 8, generator=g),
                         torch.rand(3, 8, generator=g), torch.rand(3, 8, generator=g), torch.tensor([0, 1, 0]), 2,
                         goal=torch.rand(3, 10, generator=g), phase=out)
    assert row.shape[1] == policy.manager.in_dim and policy(row)["translation"].shape == (3, 3)


def test_manager_without_prior_features_ignores_them_and_the_skip_reads_the_geometry() -> None:
    cfg = ResidualConfig(feature_dim=5, text_dim=8, hidden=16, goal_dim=10, phase_dim=4, geometric_skip=True,
                         read_prior_features=False)
    manager = ResidualPolicy(cfg, SkillBasis.from_verbs(FakeEncoder())).manager
    layout = cfg.layout()
    assert layout["phase"].stop == manager.in_dim
    x = torch.rand(2, manager.in_dim, generator=torch.Generator().manual_seed(2))
    changed = x.clone()
    changed[:, layout["features"]] += 5.0
    for a, b in zip(manager(x), manager(changed)):
        torch.testing.assert_close(a, b)  # the prior's features do not reach the Manager
    moved = x.clone()
    moved[:, layout["goal"]] += 1.0
    _, h = manager(x)
    _, h_moved = manager(moved)
    assert not torch.allclose(h, h_moved)


def test_the_prior_proposal_features_take_their_own_columns_and_a_wrong_width_is_named() -> None:
    from bimanualshift.residual.manager import manager_input_rows

    cfg = ResidualConfig(feature_dim=5, text_dim=8, proposal_dim=4)
    g = torch.Generator().manual_seed(0)
    parts = [torch.rand(2, w, generator=g) for w in (5, 9, 8, 8, 8)]
    proposal = torch.rand(2, 4, generator=g)
    rows = manager_input_rows(cfg, *parts, torch.tensor([0, 1]), torch.tensor([0, 3]), proposal=proposal)
    assert rows.shape == (2, cfg.layout()["proposal"].stop)
    torch.testing.assert_close(rows[:, cfg.layout()["proposal"]], proposal)
    assert ResidualPolicy(cfg, SkillBasis.from_verbs(FakeEncoder()))(rows)["translation"].shape == (2, 3)
    with pytest.raises(ValueError, match="4-wide proposal"):
        manager_input_rows(cfg, *parts, torch.tensor([0, 1]), torch.tensor([0, 3]))
    with pytest.raises(ValueError, match="got 3 columns"):
        manager_input_rows(cfg, *parts, torch.tensor([0, 1]), torch.tensor([0, 3]), proposal=proposal[:, :3])


def test_a_residual_trained_on_the_goal_box_reads_the_box_of_a_wider_goal_row() -> None:
    from bimanualshift.perception.goal_geometry import BOX_GEOMETRY_DIM, GOAL_GEOMETRY_DIM, UNION_GEOMETRY_DIM
    from bimanualshift.residual.manager import manager_input_rows

    g = torch.Generator().manual_seed(0)
    parts = [torch.rand(2, w, generator=g) for w in (5, 9, 8, 8, 8)]
    goal = torch.rand(2, GOAL_GEOMETRY_DIM, generator=g)  # what today's projection gives: box, extremities, objects
    for width in (BOX_GEOMETRY_DIM, UNION_GEOMETRY_DIM, GOAL_GEOMETRY_DIM):
        cfg = ResidualConfig(feature_dim=5, text_dim=8, goal_dim=width)
        rows = manager_input_rows(cfg, *parts, torch.tensor([0, 1]), torch.tensor([0, 3]), goal=goal)
        torch.testing.assert_close(rows[:, cfg.layout()["goal"]], goal[:, :width])
    with pytest.raises(ValueError, match="got 9 columns"):  # narrower than the residual reads: a wrong prior step
        manager_input_rows(ResidualConfig(feature_dim=5, text_dim=8, goal_dim=BOX_GEOMETRY_DIM), *parts,
                           torch.tensor([0, 1]), torch.tensor([0, 3]), goal=goal[:, :9])


def test_gripper_down_quaternion_sign_gives_the_manager_one_row_for_q_and_minus_q() -> None:
    from bimanualshift.memory.reference import REFERENCE_DIM
    from bimanualshift.residual.manager import manager_input_rows

    g = torch.Generator().manual_seed(0)
    features, proprio, other, text, base = (torch.rand(2, w, generator=g) for w in (5, 9, 8, 8, 8))
    reference = torch.rand(2, REFERENCE_DIM, generator=g)
    for part in (proprio, other, base, reference):
        part[:, 3:7] = torch.tensor([0.999, 0.01, 0.0, 0.04])  # near the gripper-down pose, w > 0

    def negated(part: torch.Tensor) -> torch.Tensor:
        out = part.clone()
        out[:, 3:7] = -out[:, 3:7]
        return out

    arm, keyframe = torch.tensor([0, 1]), torch.tensor([0, 3])
    for sign, same in (("gripper_down", True), ("w_positive", False)):
        cfg = ResidualConfig(feature_dim=5, text_dim=8, reference_dim=REFERENCE_DIM, quaternion_sign=sign)
        rows = manager_input_rows(cfg, features, proprio, other, text, base, arm, keyframe, reference=reference)
        flipped = manager_input_rows(cfg, features, negated(proprio), negated(other), text, negated(base), arm,
                                     keyframe, reference=negated(reference))
        assert torch.equal(rows, flipped) == same
    with pytest.raises(ValueError, match="quaternion_sign is one of"):
        ResidualConfig(quaternion_sign="xyz")
    from bimanualshift.training.configs import ResidualModelConfig

    assert ResidualModelConfig(quaternion_sign="gripper_down").residual_config(5, 8).quaternion_sign == "gripper_down"


def test_a_residual_config_from_before_the_quaternion_sign_reads_w_positive() -> None:
    from bimanualshift.utils.config_files import config_from_dict

    old = {k: v for k, v in ResidualConfig(feature_dim=5, text_dim=8).__dict__.items() if k != "quaternion_sign"}
    assert config_from_dict(ResidualConfig, old, "old residual", ignore_unknown=False).quaternion_sign == "w_positive"


def test_the_manager_width_is_a_switch_and_sets_the_residual_size() -> None:
    from bimanualshift.training.configs import ResidualModelConfig

    sizes = {}
    for hidden in (32, 256):
        cfg = ResidualModelConfig(hidden=hidden).residual_config(16, 8)
        assert cfg.hidden == hidden
        policy = ResidualPolicy(cfg, SkillBasis(cfg.num_skills, 8))
        assert policy.manager.trunk[0].out_features == hidden
        sizes[hidden] = sum(p.numel() for p in policy.parameters())
    assert sizes[32] < sizes[256] / 3
    with pytest.raises(ValueError, match="hidden"):
        ResidualModelConfig(hidden=0).residual_config(16, 8)
