"""Baseline: a PerAct²-style bimanual voxel policy trained from scratch on the bimanual demos only.

One network serves both arms (as PerAct² shares one trunk between its two arm heads): it sees the global scene
(no arm-conditioned projection) in the acting arm's frame, and its proprioception is extended with the other
arm's pose and the acting arm's one-hot, so it can coordinate the two. No single-arm pretraining, no residual:
the comparison BimanualShift's data-efficiency claim is about.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.encoders.text import TextEncoder
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.methods.baselines.voxel_policy import VoxelNetworkRunner
from bimanualshift.methods.registry import TrainRequest
from bimanualshift.training.bimanual_voxel import OWN_PROPRIO, VoxelNetworkSpec, train_voxel_network
from bimanualshift.training.samples import ArmSamples

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


def train_scratch_voxel(request: TrainRequest, size: str = "default", lr: float = 1e-3, batch_size: int = 4,
                        checkpoint_every: int = 250) -> Path:
    return train_voxel_network(SPEC, request, Path(request.out), size, lr, batch_size, checkpoint_every)


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
