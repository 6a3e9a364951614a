"""Running a prior-style network (it reads voxels or the arm's cloud) for one arm on the global scene, with extra
proprioception: the shared piece of the baselines that train or fine-tune a backbone on bimanual demos."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.encoders.text import TextEncoder
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.methods.baselines.network_spec import OWN_PROPRIO
from bimanualshift.methods.prior_step import world_action
from bimanualshift.perception.observation import ArmObservation, ArmObservationBuilder, arm_frames
from bimanualshift.priors.base import PriorOutput, UnimanualPrior


@dataclass
class SceneView:
    obs: KeyframeObservation
    per_arm: dict[str, ArmObservation]
    frames: dict[str, ArmFrame]
    text: torch.Tensor


class VoxelNetworkRunner:
    def __init__(self, checkpoint: str | Path, text_encoder: TextEncoder, proprio_dim: int) -> None:
        model = UnimanualPrior.from_pretrained(checkpoint)
        if model.config.proprio_dim != proprio_dim:
            raise ValueError(f"{checkpoint} reads {model.config.proprio_dim} proprio values; this policy gives "
                             f"{proprio_dim}: was it trained for another baseline?")
        self.model = model.freeze()
        self.text_encoder = text_encoder
        self.builder = ArmObservationBuilder(VoxelGrid(tuple(model.config.bounds), model.config.voxel_size),
                                             points=model.cloud_points, voxels=model.observation == "voxels")

    def view(self, obs: KeyframeObservation) -> SceneView:
        return SceneView(obs, self.builder.build(obs), arm_frames(obs),
                         torch.as_tensor(self.text_encoder.encode([obs.instruction])))

    def predict(self, view: SceneView, arm: str, extra: np.ndarray) -> PriorOutput:
        own = self.model.arm_proprio(view.per_arm[arm].proprio, view.obs.keyframe_index)
        proprio = np.concatenate([own[:OWN_PROPRIO], np.asarray(extra, np.float32).ravel(), own[OWN_PROPRIO:]])
        scene = self.model.observation_input(view.per_arm[arm].voxels, view.per_arm[arm].points)
        return self.model.predict(torch.as_tensor(scene)[None].float(), torch.as_tensor(proprio)[None], view.text)

    def act(self, view: SceneView, arm: str, extra: np.ndarray) -> np.ndarray:
        out = self.predict(view, arm, extra)
        return world_action(view.frames[arm], out.position[0].numpy(), out.quat[0].numpy(),
                            float(out.gripper_open[0]), float(out.ignore_collisions[0]))
