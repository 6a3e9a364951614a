"""The AnyBimanual-style baseline: per-arm soft masks, skill-weighted language, fine-tuning from the prior."""

from __future__ import annotations

from pathlib import Path

import torch
from safetensors.torch import load_file

from bimanualshift.methods.baselines.anybimanual import AnyBimanualNetwork, AnyBimanualPolicy, build_anybimanual
from bimanualshift.priors import UnimanualPrior
from bimanualshift.registry import TrainRequest, get_method
from bimanualshift.rollout.loop import rollout
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.training.checkpoint import latest_checkpoint


def test_masks_depend_on_the_arm_and_start_near_one(demo_root: Path, tmp_path: Path) -> None:
    from tests.training.test_train_resume import pretrain, pretrain_cfg

    prior = UnimanualPrior.from_pretrained(pretrain(pretrain_cfg(demo_root, tmp_path / "prior", steps=2)))
    net = build_anybimanual(prior, 10, "debug")
    voxels, text = torch.rand(2, 4, 16, 16, 16), torch.randn(2, 384)
    proprio = torch.zeros(2, 19)
    proprio[0, 16], proprio[1, 17] = 1.0, 1.0  # left, right
    mask = net.soft_mask(voxels, proprio, text)
    assert mask.shape == (2, 1, 16, 16, 16) and bool((mask > 0.95).all())  # starts close to the whole scene
    torch.testing.assert_close(net.skill_language(text), text)  # the skill gate starts closed
    with torch.no_grad():
        net.mask_out.weight.normal_()
    mask = net.soft_mask(voxels[:1].expand(2, -1, -1, -1, -1), proprio, text[:1].expand(2, -1))
    assert not torch.allclose(mask[0], mask[1])  # the same scene, masked differently for each arm
    net.save_pretrained(tmp_path / "net")
    loaded = UnimanualPrior.from_pretrained(tmp_path / "net")
    assert isinstance(loaded, AnyBimanualNetwork)
    torch.testing.assert_close(loaded.predict(voxels, proprio, text).position,
                               net.predict(voxels, proprio, text).position)


def test_trains_from_the_prior_and_acts(demo_root: Path, tmp_path: Path) -> None:
    from tests.training.test_train_resume import pretrain, pretrain_cfg

    prior = pretrain(pretrain_cfg(demo_root, tmp_path / "prior", steps=2))
    request = TrainRequest(task="push_two_buttons", data=str(demo_root / "bimanual"),
                           validation_data=str(demo_root / "bimanual"), demos=2, prior=str(prior),
                           out=str(tmp_path / "ab"), steps=2, overrides={"checkpoint_every": 2})
    spec = get_method("anybimanual")
    best = spec.train(request)
    before = UnimanualPrior.from_pretrained(prior).state_dict()
    trained = load_file(str(latest_checkpoint(tmp_path / "ab") / "model.safetensors"))
    # The backbone itself is fine-tuned (unlike BimanualShift's frozen prior).
    assert any(not torch.equal(before[k], trained[k]) for k in before if k != "proprio_proj.weight")
    policy = spec.load(best, request)
    assert isinstance(policy, AnyBimanualPolicy)
    env = ManipulationEnv("push_two_buttons", image_size=64)
    try:
        assert rollout(env, policy, seed=200_000, max_keyframes=1).keyframes == 1
    finally:
        env.close()
