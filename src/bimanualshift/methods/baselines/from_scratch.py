"""Baselines trained from scratch on the bimanual demos only: a PerAct²-style voxel policy, a Diffusion Policy
and ACT.

One network serves both arms (as PerAct² shares one trunk between its two arm heads): it sees the global scene
(no arm-conditioned projection) in the acting arm's frame, and its proprioception is extended with the other
arm's pose and the acting arm's one-hot, so it can coordinate the two. No single-arm pretraining, no residual:
the comparison BimanualShift's data-efficiency claim is about.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.encoders.text import TextEncoder
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.methods.baselines.network_spec import OWN_PROPRIO, VoxelNetworkSpec
from bimanualshift.methods.baselines.voxel_policy import VoxelNetworkRunner
from bimanualshift.perception.arm_samples import ArmSamples

ARMS = ("left", "right")
EXTRA_PROPRIO = 8 + len(ARMS)  # the other arm's pose and gripper, the acting arm's one-hot


def scratch_extras(other_proprio: np.ndarray, arm: list[str] | tuple[str, ...]) -> np.ndarray:
    """(N, 8) the other arm in this arm's frame, arm names -> (N, 10): other arm, one-hot of the acting arm."""
    onehot = np.eye(len(ARMS), dtype=np.float32)[[ARMS.index(a) for a in arm]]
    return np.concatenate([other_proprio, onehot], axis=1).astype(np.float32)


def sample_extras(samples: ArmSamples, frames: list[dict[str, ArmFrame]]) -> np.ndarray:
    return scratch_extras(samples.other_proprio, samples.arm)


SPEC = VoxelNetworkSpec("scratch_voxel", arms=ARMS, extra_dim=EXTRA_PROPRIO, extra_proprio=sample_extras,
                        extra_poses=(0,))


DP_SPEC = replace(SPEC, name="scratch_dp", kind="diffusion")
ACT_SPEC = replace(SPEC, name="scratch_act", kind="act")


class ScratchVoxelPolicy:
    name = "scratch_voxel"

    def __init__(self, checkpoint: str | Path, text_encoder: TextEncoder) -> None:
        self.runner = VoxelNetworkRunner(checkpoint, text_encoder, OWN_PROPRIO + EXTRA_PROPRIO)

    def reset(self) -> None:
        pass

    @torch.no_grad()
    def act(self, obs: KeyframeObservation) -> np.ndarray:
        view = self.runner.view(obs)
        rows = [self.runner.act(view, arm, scratch_extras(view.per_arm[arm].other_proprio[None], [arm]))
                for arm in obs.scene.arm_names]
        return np.stack(rows)


class ScratchDiffusionPolicy(ScratchVoxelPolicy):
    """Acts like the voxel one: the runner feeds any prior network the same observation and proprioception."""

    name = "scratch_dp"


class ScratchACTPolicy(ScratchVoxelPolicy):
    name = "scratch_act"
