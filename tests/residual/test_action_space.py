"""The action-space residual: logits added to the frozen prior's own translation heat-map (on a lattice around
its proposal) and rotation bins. Untrained it leaves the prior's action unchanged; its logits move the action to
another lattice cell or bin; its loss is the cross-entropy of the summed logits; both heat-map priors expose the
scores it needs."""

from __future__ import annotations

import numpy as np
import torch

from bimanualshift.configs import prior_model_config
from bimanualshift.geometry.frames import ArmFrame, euler_bins_to_quat
from bimanualshift.methods.bimanualshift import BimanualShift
from bimanualshift.methods.prior_step import ArmStep, world_action
from bimanualshift.priors import PRIORS
from bimanualshift.priors.base import PriorOutput
from bimanualshift.residual.manager import ResidualConfig, ResidualPolicy, action_lattice
from bimanualshift.residual.skills import SkillBasis
from bimanualshift.training.configs import ResidualModelConfig
from bimanualshift.training.residual_data import ResidualData
from bimanualshift.training.residual_losses import LossWeights, bc_loss
from tests.residual.test_residual import FakeEncoder, inputs

FRAME = ArmFrame((0.0, -0.3, 0.8))
BINS = 36


def config() -> ResidualConfig:
    return ResidualConfig(feature_dim=5, text_dim=8, hidden=16, gripper_residual=True, hold=True, action_space=True,
                          action_window=3, action_cell_m=0.02, rotation_bins=BINS)


class HeatmapPrior:
    """A prior whose translation log-probability peaks at its proposal and falls with the distance."""

    rotation_bin_degrees = 10.0

    def translation_scores(self, out: PriorOutput, points: torch.Tensor) -> torch.Tensor:
        return -((points - out.position[:, None]) ** 2).sum(-1) * 100


def step() -> ArmStep:
    rotation = torch.full((1, 3, BINS), -5.0)
    rotation[0, :, 0] = 5.0  # the prior's bins: 0, 0, 0
    prior = PriorOutput(position=torch.tensor([[0.5, 0.0, 0.1]]), quat=torch.tensor([[0.0, 0.0, 0.0, 1.0]]),
                        gripper_open=torch.tensor([0.9]), ignore_collisions=torch.tensor([0.0]),
                        features=torch.zeros(1, 5), logits={"rotation": rotation})
    return ArmStep(FRAME, np.r_[0.4, 0.1, 0.2, 0, 0, 0, 1, 1.0, 0.0].astype(np.float32), np.zeros(8, np.float32),
                   prior, np.zeros(0, np.float32))


def method(cfg: ResidualConfig) -> BimanualShift:
    policy = BimanualShift.__new__(BimanualShift)  # only the action rule is exercised
    policy._last_action = {}
    policy.residual = ResidualPolicy(cfg, SkillBasis.from_verbs(FakeEncoder()))
    policy.prior_step = type("Step", (), {"prior": HeatmapPrior()})()
    return policy


def test_the_switch_builds_the_outputs_and_turns_the_gate_off() -> None:
    cfg = ResidualModelConfig(action_space=True, action_window=3).residual_config(5, 8, 0, BINS)
    assert cfg.action_space and cfg.rotation_bins == BINS and not cfg.output_gate
    assert cfg.extra_outputs == 2 + 27 + 3 * BINS
    assert ResidualModelConfig().residual_config(5, 8).extra_outputs == 2  # off by default
    lattice = action_lattice(config())
    assert lattice.shape == (27, 3) and torch.equal(lattice[13], torch.zeros(3))
    out = ResidualPolicy(config(), SkillBasis.from_verbs(FakeEncoder()))(inputs())
    assert out["translation_logits"].shape == (len(inputs()), 27) and out["rotation_logits"].shape[1:] == (3, BINS)
    assert (out["hold_logit"] < 0).all() and torch.all(out["translation_logits"] == 0)  # untrained: adds nothing


def test_untrained_it_keeps_the_prior_action_and_its_logits_move_it() -> None:
    policy = method(config())
    zero = {"translation": torch.zeros(1, 3), "rotation": torch.zeros(1, 3), "gripper_logit": torch.tensor([2.2]),
            "hold_logit": torch.tensor([-4.0]), "translation_logits": torch.zeros(1, 27),
            "rotation_logits": torch.zeros(1, 3, BINS)}
    action, held = policy.final_action("left", step(), zero)
    np.testing.assert_allclose(action, world_action(FRAME, np.array([0.5, 0.0, 0.1]), np.array([0, 0, 0, 1.0]),
                                                    0.9, 0.0), atol=1e-6)
    pushed = dict(zero)
    pushed["translation_logits"] = torch.zeros(1, 27)
    pushed["translation_logits"][0, 22] = 50.0  # cell (2, 1, 1): +2 cm in x
    pushed["rotation_logits"] = torch.zeros(1, 3, BINS)
    pushed["rotation_logits"][0, 2, 9] = 20.0  # yaw bin 9 (90 deg)
    action, _ = policy.final_action("left", step(), pushed)
    expected = world_action(FRAME, np.array([0.52, 0.0, 0.1]), euler_bins_to_quat(np.array([0, 0, 9]), 10.0), 0.9, 0)
    np.testing.assert_allclose(action, expected, atol=1e-5)


def test_its_loss_is_the_cross_entropy_of_the_summed_logits() -> None:
    n = 4
    prior_t = torch.log_softmax(torch.randn(n, 27), -1)
    prior_r = torch.log_softmax(torch.randn(n, 3, BINS), -1)
    data = ResidualData(torch.zeros(n, 1), torch.zeros(n, 3), torch.zeros(n, 3), gripper=torch.ones(n),
                        hold=torch.zeros(n), prior_translation=prior_t, prior_rotation=prior_r,
                        target_cell=torch.tensor([0, 13, 26, 5]), target_bins=torch.zeros(n, 3, dtype=torch.long))
    out = {"translation": torch.zeros(n, 3), "rotation": torch.zeros(n, 3), "gripper_logit": torch.zeros(n),
           "hold_logit": torch.zeros(n), "translation_logits": torch.zeros(n, 27, requires_grad=True),
           "rotation_logits": torch.zeros(n, 3, BINS)}
    losses = bc_loss(out, data, LossWeights())
    expected = torch.nn.functional.cross_entropy(prior_t, data.target_cell)
    torch.testing.assert_close(losses["translation"], expected)
    losses["total"].backward()
    grad = out["translation_logits"].grad
    assert (grad[torch.arange(n), data.target_cell] < 0).all()  # raising the expert's cell lowers the loss


def test_heatmap_priors_score_their_own_proposal_highest_nearby() -> None:
    torch.manual_seed(0)
    for name in ("peract", "rvt"):
        prior = PRIORS[name](PRIORS[name].config_class(**prior_model_config(name, "debug"))).eval()
        text = torch.zeros(1, prior.config.text_dim)
        proprio = torch.zeros(1, prior.config.proprio_dim + 1)
        scene = (torch.rand(1, 4, *[prior.config.voxel_size] * 3) if prior.observation == "voxels"
                 else torch.rand(1, prior.config.num_points, 6) * 0.2)
        out = prior.predict(scene, proprio, text)
        cells = out.position[:, None] + action_lattice(ResidualConfig(action_window=3, action_cell_m=0.01))[None]
        scores = prior.translation_scores(out, cells)
        assert scores.shape == (1, 27) and torch.isfinite(scores).all()
        assert prior.rotation_bin_degrees > 0
        if name == "peract":  # its proposal lies in its heat-map's peak voxel: no lattice cell scores higher
            assert scores[0, 13] == scores.max()
