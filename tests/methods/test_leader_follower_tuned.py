"""PerAct-LF: the leader's action in the follower's frame, a follower that starts as the prior, training, rollout."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from bimanualshift.configs import prior_model_config
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.methods.baselines.leader_follower_tuned import LeaderFollowerPolicy, leader_extras
from bimanualshift.methods.baselines.network_spec import widen_from_prior
from bimanualshift.perception.arm_samples import ArmSamples
from bimanualshift.priors import PRIORS
from bimanualshift.registry import TrainRequest, get_method
from bimanualshift.rollout.loop import rollout
from bimanualshift.sim.env import ManipulationEnv


def test_follower_sees_the_leaders_action_in_its_own_frame() -> None:
    n = 2
    samples = ArmSamples(np.zeros((n, 4, 2, 2, 2), np.float16), np.zeros((n, 9), np.float32), ["x"] * n,
                         np.array([[0.4, 0.0, 0.2], [0.5, 0.0, 0.1]]), np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)),
                         np.array([1, 0]), np.zeros(n, np.int64), np.zeros(n), np.zeros(n), ["left", "right"],
                         np.zeros((n, 8), np.float32))
    frames = [{"left": ArmFrame((0.0, 0.3, 0.0)), "right": ArmFrame((0.0, -0.3, 0.0))}]
    extra = leader_extras(samples, frames)
    # The right arm's target (0.5, 0, 0.1) in its frame is (0.5, -0.3, 0.1) in the world, (0.5, -0.6, 0.1) for left.
    np.testing.assert_allclose(extra[0, :3], [0.5, -0.6, 0.1], atol=1e-6)
    np.testing.assert_allclose(np.abs(extra[0, 3:7]), [0, 0, 0, 1], atol=1e-6)
    assert extra[0, 7] == 0.0  # the leader's gripper is closed at that keyframe
    np.testing.assert_array_equal(extra[1], np.zeros(8))  # the leader's own row carries nothing


def test_widened_follower_starts_as_the_prior() -> None:
    cls = PRIORS["peract"]
    torch.manual_seed(0)
    prior = cls(cls.config_class(**prior_model_config("peract", "debug")))
    wide = cls(cls.config_class(**{**prior_model_config("peract", "debug"), "proprio_dim": 16}))
    widen_from_prior(wide, prior, 8)
    voxels, text = torch.rand(1, 4, 16, 16, 16), torch.randn(1, 384)
    own = torch.rand(1, 9)
    extra = torch.randn(1, 8)  # whatever the leader does, the untrained follower acts like the prior
    a = prior.predict(voxels, own, text)
    b = wide.predict(voxels, torch.cat([own[:, :8], extra, own[:, 8:]], dim=1), text)
    torch.testing.assert_close(a.position, b.position)
    torch.testing.assert_close(a.quat, b.quat)


def test_pair_trains_from_the_prior_and_acts(demo_root: Path, tmp_path: Path) -> None:
    from tests.training.test_train_resume import pretrain, pretrain_cfg

    prior = pretrain(pretrain_cfg(demo_root, tmp_path / "prior", steps=2))
    request = TrainRequest(task="push_two_buttons", data=str(demo_root / "bimanual"),
                           validation_data=str(demo_root / "bimanual"), demos=2, prior=str(prior),
                           out=str(tmp_path / "lf"), steps=2, overrides={"checkpoint_every": 2})
    spec = get_method("peract_lf")
    pair = spec.train(request)
    assert spec.train(request) == pair  # a finished pair is not trained again
    policy = spec.load(pair, request)
    assert isinstance(policy, LeaderFollowerPolicy)
    assert policy.follower.model.config.proprio_dim == 16 and policy.leader.model.config.proprio_dim == 8
    env = ManipulationEnv("push_two_buttons", image_size=64)
    try:
        assert rollout(env, policy, seed=200_000, max_keyframes=1).keyframes == 1
    finally:
        env.close()


def test_continual_pair_starts_from_the_earlier_pair(demo_root: Path, tmp_path: Path) -> None:
    import json

    from bimanualshift.priors.base import UnimanualPrior
    from tests.training.test_train_resume import pretrain, pretrain_cfg

    prior = pretrain(pretrain_cfg(demo_root, tmp_path / "prior", steps=2))

    def request(out: str, **overrides: object) -> TrainRequest:
        return TrainRequest(task="push_two_buttons", data=str(demo_root / "bimanual"),
                            validation_data=str(demo_root / "bimanual"), demos=2, prior=str(prior),
                            out=str(tmp_path / out), steps=2, overrides={"checkpoint_every": 2, **overrides})

    spec = get_method("peract_lf")
    assert spec.continual
    first = spec.train(request("first", lr=5e-2))
    # A negligible lr (LAMB refuses 0): each network hands on the weights it started from.
    second = spec.train(request("second", lr=1e-12, init_from=str(first)))
    pairs = [json.loads((p / "pair.json").read_text()) for p in (first, second)]
    for role in ("leader", "follower"):
        a, b = (UnimanualPrior.from_pretrained(p[role]).state_dict() for p in pairs)
        for k in a:
            torch.testing.assert_close(a[k], b[k], atol=1e-6, rtol=0, msg=f"{role} {k}")
    with pytest.raises(FileNotFoundError, match="no leader-follower pair"):
        spec.train(request("third", init_from=str(tmp_path / "nowhere")))


def test_dp_pair_fine_tunes_a_diffusion_prior_and_refuses_a_voxel_one(demo_root: Path, tmp_path: Path) -> None:
    from bimanualshift.methods.baselines.leader_follower_tuned import DiffusionLeaderFollowerPolicy
    from bimanualshift.priors.base import UnimanualPrior
    from tests.training.test_train_resume import pretrain, pretrain_cfg

    dp = pretrain(pretrain_cfg(demo_root, tmp_path / "dp", steps=2, prior="dp"))
    voxel = pretrain(pretrain_cfg(demo_root, tmp_path / "voxel", steps=2))

    def request(out: str, prior: Path) -> TrainRequest:
        return TrainRequest(task="push_two_buttons", data=str(demo_root / "bimanual"),
                            validation_data=str(demo_root / "bimanual"), demos=2, prior=str(voxel),
                            out=str(tmp_path / out), steps=2, overrides={"checkpoint_every": 2, "prior": str(prior)})

    spec = get_method("dp_lf")
    pair = spec.train(request("pair", dp))
    policy = spec.load(pair, request("pair", dp))
    assert isinstance(policy, DiffusionLeaderFollowerPolicy) and policy.name == "dp_lf"
    follower = UnimanualPrior.from_pretrained(json.loads((pair / "pair.json").read_text())["follower"])
    assert follower.config.type == "diffusion" and follower.config.proprio_dim == 16
    env = ManipulationEnv("push_two_buttons", image_size=64)
    try:
        assert rollout(env, policy, seed=200_000, max_keyframes=1).keyframes == 1
    finally:
        env.close()
    with pytest.raises(ValueError, match="fine-tunes a diffusion prior"):
        spec.train(request("wrong", voxel))


def test_widened_rvt_follower_starts_as_the_prior_in_both_stages() -> None:
    cls = PRIORS["rvt"]
    torch.manual_seed(0)
    prior = cls(cls.config_class(**prior_model_config("rvt", "debug")))
    wide = cls(cls.config_class(**{**prior_model_config("rvt", "debug"), "proprio_dim": 16}))
    widen_from_prior(wide, prior, 8)
    g = torch.Generator().manual_seed(1)
    cloud = torch.cat([torch.tensor([0.2, -0.45, -0.15]) + torch.rand(1, 256, 3, generator=g) * torch.tensor(
        [0.7, 0.9, 0.5]), torch.rand(1, 256, 3, generator=g)], -1)
    own, text = torch.rand(1, 9, generator=g), torch.randn(1, 384, generator=g)
    a = prior.predict(cloud, own, text)
    b = wide.predict(cloud, torch.cat([own[:, :8], torch.randn(1, 8, generator=g), own[:, 8:]], dim=1), text)
    torch.testing.assert_close(a.coarse_position, b.coarse_position)  # the coarse stage ignores the leader ...
    torch.testing.assert_close(a.position, b.position)  # ... and so does the fine one


def test_rvt_pair_trains_from_an_rvt_prior_and_acts(demo_root: Path, tmp_path: Path) -> None:
    from tests.training.test_train_resume import pretrain, pretrain_cfg

    prior = pretrain(pretrain_cfg(demo_root, tmp_path / "prior", steps=2, prior="rvt"))
    request = TrainRequest(task="push_two_buttons", data=str(demo_root / "bimanual"),
                           validation_data=str(demo_root / "bimanual"), demos=2, prior="peract_suite",
                           out=str(tmp_path / "lf"), steps=2, overrides={"checkpoint_every": 2, "prior": str(prior)})
    spec = get_method("rvt_lf")
    pair = spec.train(request)
    assert json.loads((pair / "pair.json").read_text())["type"] == "rvt_lf"
    policy = spec.load(pair, request)
    assert policy.name == "rvt_lf" and policy.follower.model.config.type == "rvt"
    env = ManipulationEnv("push_two_buttons", image_size=64)
    try:
        assert rollout(env, policy, seed=200_000, max_keyframes=1).keyframes == 1
    finally:
        env.close()
