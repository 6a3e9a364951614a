"""The residual's coordination outputs (a gripper logit and a per-arm hold), their training targets and the
paper-literal switch that turns them off."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.methods.bimanualshift import BimanualShift
from bimanualshift.methods.prior_step import ArmStep, world_action
from bimanualshift.perception.arm_samples import ArmSamples
from bimanualshift.priors.base import PriorOutput
from bimanualshift.residual.manager import ResidualConfig, ResidualPolicy
from bimanualshift.residual.skills import SkillBasis
from bimanualshift.training.configs import ResidualModelConfig
from bimanualshift.training.residual_data import ResidualData, hold_labels
from bimanualshift.training.residual_losses import LossWeights, bc_loss
from tests.residual.test_residual import FakeEncoder, inputs

FRAME = ArmFrame((0.0, -0.3, 0.8))
IDENTITY = np.array([0.0, 0.0, 0.0, 1.0], np.float32)


def residual(gripper: bool, hold: bool) -> ResidualPolicy:
    cfg = ResidualConfig(feature_dim=5, text_dim=8, hidden=16, gripper_residual=gripper, hold=hold)
    return ResidualPolicy(cfg, SkillBasis.from_verbs(FakeEncoder()))


def step(gripper_open: float = 0.9) -> ArmStep:
    prior = PriorOutput(position=torch.tensor([[0.5, 0.0, 0.1]]), quat=torch.as_tensor(IDENTITY)[None],
                        gripper_open=torch.tensor([gripper_open]), ignore_collisions=torch.tensor([0.0]),
                        features=torch.zeros(1, 5))
    proprio = np.r_[0.4, 0.1, 0.2, IDENTITY, 0.0, 0.0].astype(np.float32)  # closed gripper, keyframe 0
    return ArmStep(FRAME, proprio, np.zeros(8, np.float32), prior, np.zeros(0, np.float32))


def method() -> BimanualShift:
    policy = BimanualShift.__new__(BimanualShift)  # only the action rule is exercised: no prior, no env
    policy._last_action = {}
    return policy


def out(translation: tuple = (0.0, 0.0, 0.0), **logits: float) -> dict[str, torch.Tensor]:
    return {"translation": torch.tensor([translation]), "rotation": torch.zeros(1, 3),
            **{k: torch.tensor([v]) for k, v in logits.items()}}


def test_the_paper_literal_switch_restores_translation_and_rotation_only() -> None:
    literal = ResidualModelConfig(paper_literal=True).residual_config(5, 8)
    assert not literal.gripper_residual and not literal.hold and literal.extra_outputs == 0
    full = ResidualModelConfig().residual_config(5, 8)
    assert full.gripper_residual and full.hold
    x = inputs()
    assert residual(False, False).g.out_features == 6 and set(residual(False, False)(x)) == {
        "translation", "rotation", "weights", "v"}
    # a paper-literal residual's action is the prior's position + G's translation, with the prior's gripper
    action, held = method().final_action("left", step(), out((0.01, 0.0, 0.0)))
    expected = world_action(FRAME, np.array([0.51, 0.0, 0.1]), IDENTITY, 0.9, 0.0)
    np.testing.assert_allclose(action, expected, atol=1e-6)
    assert not held and action[7] == 1.0


def test_an_untrained_coordinating_residual_leaves_the_prior_action_unchanged() -> None:
    x = inputs()
    with torch.no_grad():
        o = residual(True, True)(x)
    prior_open = x[:, ResidualConfig(feature_dim=5, text_dim=8).layout()["base_action"].start + 7]
    torch.testing.assert_close(torch.sigmoid(o["gripper_logit"]), prior_open)  # the prior's own probability
    assert (o["hold_logit"] < 0).all()  # nobody holds
    action, held = method().final_action("left", step(), {k: v[:1] for k, v in o.items()})
    literal, _ = method().final_action("left", step(), out())
    np.testing.assert_allclose(action, literal, atol=1e-6)
    assert not held


def test_the_gripper_residual_overrides_the_prior_open_close() -> None:
    action, _ = method().final_action("left", step(gripper_open=0.9), out(gripper_logit=-3.0))
    assert action[7] == 0.0  # the residual's logit closes a gripper the prior would open
    action, _ = method().final_action("left", step(gripper_open=0.1), out(gripper_logit=2.0))
    assert action[7] == 1.0


def test_a_hold_repeats_the_arm_last_action_or_keeps_its_pose() -> None:
    policy = method()
    first, held = policy.final_action("left", step(), out(hold_logit=3.0))
    assert held  # no earlier action: the arm's current pose and gripper (closed)
    np.testing.assert_allclose(first, world_action(FRAME, np.array([0.4, 0.1, 0.2]), IDENTITY, 0.0, 0.0), atol=1e-6)
    moved, held = policy.final_action("left", step(), out((0.02, 0.0, 0.0), hold_logit=-3.0))
    assert not held
    policy._last_action["left"] = moved
    again, held = policy.final_action("left", step(), out((0.05, 0.0, 0.0), hold_logit=3.0))
    assert held and np.array_equal(again, moved)  # the residual's own translation is ignored while holding


def _samples() -> ArmSamples:
    """One episode, two arms, three keyframes: the right arm waits at keyframes 1-2, the left arm moves."""
    pos = {"left": [[0.5, 0, 0.1], [0.5, 0, 0.05], [0.5, 0, 0.05]], "right": [[0.4, 0, 0.2]] * 3}
    grip = {"left": [1, 1, 0], "right": [1, 1, 1]}
    rows = [(k, arm) for k in range(3) for arm in ("left", "right")]
    n = len(rows)
    return ArmSamples(voxels=None, proprio=np.zeros((n, 9), np.float32), instructions=["x"] * n,
                      action_pos=np.array([pos[a][k] for k, a in rows], np.float32),
                      action_quat=np.tile(IDENTITY, (n, 1)), gripper_open=np.array([grip[a][k] for k, a in rows]),
                      ignore_collisions=np.zeros(n, np.int64), episode=np.zeros(n, np.int64),
                      keyframe=np.array([k for k, _ in rows]), arm=[a for _, a in rows],
                      other_proprio=np.zeros((n, 8), np.float32))


def test_hold_labels_mark_an_arm_repeating_its_previous_action() -> None:
    labels = dict(zip([(k, a) for k in range(3) for a in ("left", "right")], hold_labels(_samples())))
    assert labels[(1, "right")] == labels[(2, "right")] == 1.0
    assert labels[(0, "right")] == 0.0  # an episode's first keyframe is never a hold
    assert labels[(1, "left")] == 0.0  # moved 5 cm
    assert labels[(2, "left")] == 0.0  # same place, but the gripper closed


def test_bc_loss_adds_the_weighted_cross_entropies_and_refuses_missing_targets() -> None:
    policy = residual(True, True)
    x = inputs()
    data = ResidualData(x, torch.zeros(3, 3), torch.zeros(3, 3), gripper=torch.ones(3), hold=torch.zeros(3))
    losses = bc_loss(policy(x), data, LossWeights(beta=1.0, gripper=0.5, hold=0.25))
    expected = losses["translation"] + losses["rotation"] + 0.5 * losses["gripper"] + 0.25 * losses["hold"]
    torch.testing.assert_close(losses["total"], expected)
    assert losses["gripper"] > 0 and losses["hold"] > 0
    literal = bc_loss(residual(False, False)(x), data, LossWeights())
    assert set(literal) == {"translation", "rotation", "total"}
    with pytest.raises(ValueError, match="no gripper targets"):
        bc_loss(policy(x), ResidualData(x, torch.zeros(3, 3), torch.zeros(3, 3)), LossWeights())
