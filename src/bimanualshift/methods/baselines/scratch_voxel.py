"""Baseline: a PerAct²-style bimanual voxel policy trained from scratch on the bimanual demos only.

One network serves both arms (as PerAct² shares one trunk between its two arm heads): it sees the global scene
(no arm-conditioned projection) in the acting arm's frame, and its proprioception is extended with the other
arm's pose and the acting arm's one-hot, so it can coordinate the two. No single-arm pretraining, no residual:
the comparison BimanualShift's data-efficiency claim is about.
"""

from __future__ import annotations

import numpy as np
import torch

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.encoders.text import TextEncoder
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.methods.stages import world_action
from bimanualshift.perception.observation import ArmObservationBuilder, arm_frames
from bimanualshift.priors.base import UnimanualPrior

ARMS = ("left", "right")
OWN_PROPRIO = 8  # position, quaternion, gripper opening
EXTRA_PROPRIO = 8 + len(ARMS)  # the other arm's pose and gripper, the acting arm's one-hot


def bimanual_proprio(proprio: np.ndarray, other: np.ndarray, arm: list[str] | tuple[str, ...]) -> np.ndarray:
    """(N, 9) own proprio + keyframe fraction, (N, 8) other arm -> (N, 19): own, other, one-hot, fraction last."""
    onehot = np.eye(len(ARMS), dtype=np.float32)[[ARMS.index(a) for a in arm]]
    return np.concatenate([proprio[:, :OWN_PROPRIO], other, onehot, proprio[:, OWN_PROPRIO:]], axis=1
                          ).astype(np.float32)


class ScratchVoxelPolicy:
    name = "scratch_voxel"

    def __init__(self, model: UnimanualPrior, text_encoder: TextEncoder, max_keyframes: int = 25) -> None:
        if model.config.proprio_dim != OWN_PROPRIO + EXTRA_PROPRIO:
            raise ValueError(f"a from-scratch bimanual voxel policy reads {OWN_PROPRIO + EXTRA_PROPRIO} proprio "
                             f"values; this checkpoint reads {model.config.proprio_dim}")
        self.model = model.freeze()
        self.text_encoder = text_encoder
        self.builder = ArmObservationBuilder(VoxelGrid(tuple(model.config.bounds), model.config.voxel_size))
        self.max_keyframes = max_keyframes

    def reset(self) -> None:
        pass

    @torch.no_grad()
    def act(self, obs: KeyframeObservation) -> np.ndarray:
        per_arm = self.builder.build(obs)
        frames = arm_frames(obs)
        text = torch.as_tensor(self.text_encoder.encode([obs.instruction]))
        rows = []
        for arm in obs.scene.arm_names:
            own = np.r_[per_arm[arm].proprio, obs.keyframe_index / self.max_keyframes].astype(np.float32)[None]
            proprio = bimanual_proprio(own, per_arm[arm].other_proprio[None], [arm])
            out = self.model.predict(torch.as_tensor(per_arm[arm].voxels)[None].float(), torch.as_tensor(proprio),
                                     text)
            rows.append(world_action(frames[arm], out.position[0].numpy(), out.quat[0].numpy(),
                                     float(out.gripper_open[0]), float(out.ignore_collisions[0])))
        return np.stack(rows)
