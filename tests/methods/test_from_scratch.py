"""The from-scratch bimanual voxel baseline: its proprioception, augmentation, training (resume) and rollout."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
from safetensors.torch import load_file

from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.methods.baselines.from_scratch import ScratchVoxelPolicy, scratch_extras
from bimanualshift.methods.baselines.network_spec import with_extra_proprio
from bimanualshift.priors import UnimanualPrior
from bimanualshift.registry import TrainRequest, get_method
from bimanualshift.rollout.loop import rollout
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.training.augment import Se3Augmentation
from bimanualshift.training.baseline_configs import BackboneTrainConfig
from bimanualshift.training.baseline_trainers import train_scratch_voxel
from bimanualshift.training.checkpoint import latest_checkpoint
from bimanualshift.training.pretrain import augment_batch


def test_extra_proprio_sits_between_own_proprio_and_keyframe_fraction() -> None:
    from bimanualshift.perception.arm_samples import ArmSamples

    n = 2
    samples = ArmSamples(np.zeros((n, 4, 2, 2, 2), np.float16), np.arange(18, dtype=np.float32).reshape(n, 9),
                         ["x"] * n, np.zeros((n, 3)), np.zeros((n, 4)), np.zeros(n, np.int64), np.zeros(n, np.int64),
                         np.zeros(n), np.zeros(n), ["left", "right"], np.full((n, 8), -1.0, np.float32))
    extra = scratch_extras(samples.other_proprio, samples.arm)
    out = with_extra_proprio(samples, extra).proprio
    assert out.shape == (2, 19)
    np.testing.assert_array_equal(out[:, :8], samples.proprio[:, :8])
    np.testing.assert_array_equal(out[:, 8:16], samples.other_proprio)
    np.testing.assert_array_equal(out[:, 16:18], [[1, 0], [0, 1]])
    np.testing.assert_array_equal(out[:, 18], samples.proprio[:, 8])


def test_augmentation_moves_the_other_arm_with_the_scene() -> None:
    grid = VoxelGrid((0.2, -0.45, -0.15, 0.9, 0.45, 0.35), 16)
    proprio = torch.zeros(1, 19)
    proprio[0, :3] = torch.tensor([0.5, 0.0, 0.1])
    proprio[0, 8:11] = torch.tensor([0.5, 0.0, 0.1])  # the other arm at the same place
    proprio[0, 6] = proprio[0, 14] = 1.0  # identity quaternions (x y z w)
    actions = {"position": torch.tensor([[[0.55, 0.05, 0.1]]]), "quat": torch.tensor([[[0.0, 0.0, 0.0, 1.0]]]),
               "gripper_open": torch.ones(1, 1, dtype=torch.long),
               "ignore_collisions": torch.zeros(1, 1, dtype=torch.long)}
    _, moved, _ = augment_batch(torch.zeros(1, 4, 16, 16, 16), proprio, actions, grid,
                                Se3Augmentation(0.04, 15.0), torch.Generator().manual_seed(1), extra_poses=(8,))
    assert not torch.equal(moved[0, :3], proprio[0, :3])
    torch.testing.assert_close(moved[0, 8:15], moved[0, :7])  # the same rigid motion for both poses


def test_trains_from_scratch_resumes_and_acts(demo_root: Path, tmp_path: Path) -> None:
    def request(out: Path, steps: int) -> TrainRequest:
        return TrainRequest(task="push_two_buttons", data=str(demo_root / "bimanual"),
                            validation_data=str(demo_root / "bimanual"), demos=2, prior="", out=str(out),
                            steps=steps, overrides={"size": "debug", "checkpoint_every": 2})

    spec = get_method("scratch_voxel")
    spec.train(request(tmp_path / "a", 2))
    best = train_scratch_voxel(request(tmp_path / "a", 4), BackboneTrainConfig(size="debug", checkpoint_every=2))
    train_scratch_voxel(request(tmp_path / "b", 4), BackboneTrainConfig(size="debug", checkpoint_every=2))
    resumed = load_file(str(latest_checkpoint(tmp_path / "a") / "model.safetensors"))
    straight = load_file(str(latest_checkpoint(tmp_path / "b") / "model.safetensors"))
    for key, value in straight.items():
        assert torch.equal(value, resumed[key]), key
    assert UnimanualPrior.from_pretrained(best).config.proprio_dim == 18  # own 8 + other arm 8 + one-hot 2
    policy = spec.load(best, request(tmp_path / "a", 4))
    assert isinstance(policy, ScratchVoxelPolicy) and policy.runner.builder.projection is None
    env = ManipulationEnv("push_two_buttons", image_size=64)
    try:
        assert rollout(env, policy, seed=200_000, max_keyframes=1).keyframes == 1
    finally:
        env.close()


@pytest.mark.parametrize(("method", "kind"), [("scratch_dp", "diffusion"), ("scratch_act", "act")])
def test_chunk_policies_from_scratch_train_and_act(demo_root: Path, tmp_path: Path, method: str, kind: str) -> None:
    request = TrainRequest(task="push_two_buttons", data=str(demo_root / "bimanual"),
                           validation_data=str(demo_root / "bimanual"), demos=2, prior="", out=str(tmp_path / method),
                           steps=2, overrides={"size": "debug", "checkpoint_every": 2})
    spec = get_method(method)
    best = spec.train(request)
    model = UnimanualPrior.from_pretrained(best)
    assert model.config.type == kind and model.config.proprio_dim == 18  # own 8 + other arm 8 + one-hot 2
    policy = spec.load(best, request)
    assert isinstance(policy, ScratchVoxelPolicy) and policy.name == method
    env = ManipulationEnv("push_two_buttons", image_size=64)
    try:
        assert rollout(env, policy, seed=200_000, max_keyframes=1).keyframes == 1
    finally:
        env.close()
