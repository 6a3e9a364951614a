"""The step every method shares at a keyframe: per-arm observations through the frozen prior."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from bimanualshift.core.threads import map_arms, policy_threads
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.encoders.text import TextEncoder
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.methods.instruction_chooser import InstructionChooser, chooser_features
from bimanualshift.perception.goal_geometry import UNION_GEOMETRY_DIM
from bimanualshift.perception.observation import ArmObservationBuilder, arm_frames
from bimanualshift.perception.projection import ArmProjection
from bimanualshift.perception.segmenters import make_segmenter
from bimanualshift.priors.base import PriorOutput, UnimanualPrior
from bimanualshift.sim.layout import WORKSPACE_HIGH, WORKSPACE_LOW


@dataclass
class ArmStep:
    """Everything a method needs about one arm at one keyframe."""

    frame: ArmFrame
    proprio: np.ndarray  # (9,) arm frame + keyframe fraction
    other_proprio: np.ndarray  # (8,) the other arm, in this arm's frame
    prior: PriorOutput  # batch of one, arm frame
    goal: np.ndarray  # (GOAL_GEOMETRY_DIM,) the goal's location in this arm's frame, from the projection
    asked: str = ""  # what the prior was asked when not the episode's instruction (``--prior-instruction``)


def goal_switches(goal_dim: int, start_goal_dim: int) -> dict[str, bool]:
    """``FrozenPriorStep``'s ``locate_goal`` and ``goal_objects`` for a residual reading these goal widths: the goal
    is located when any is read, each goal noun's box only when a width reaches past the union's geometry."""
    return {"locate_goal": goal_dim > 0 or start_goal_dim > 0,
            "goal_objects": max(goal_dim, start_goal_dim) > UNION_GEOMETRY_DIM}


class FrozenPriorStep:
    def __init__(self, prior: UnimanualPrior, text_encoder: TextEncoder, use_projection: bool = True,
                 segmenter: str = "simulator",
                 segmenter_options: dict[str, str] | None = None, locate_goal: bool = False,
                 goal_objects: bool = False,
                 proposal_features: bool = False, prior_instruction: str = "",
                 instruction_chooser: InstructionChooser | None = None) -> None:
        self.prior = prior.freeze()
        self.text_encoder = text_encoder
        # what the prior is asked instead of the episode's instruction ("" keeps the episode's: the paper); chosen
        # on the training demos by `train --prior-instruction auto` (training/prior_instruction.py)
        self.prior_instruction = prior_instruction
        # or, per arm, the instruction an arm's observation picks (`--prior-instruction per_arm`); overrides the above
        self.instruction_chooser = instruction_chooser
        self._embeddings: dict[str, torch.Tensor] = {}  # the prior's text embedding per instruction, encoded once
        # fill every output's ``proposal_features`` (priors that do not while predicting take one more pass)
        self.proposal_features = proposal_features
        cfg = prior.config
        # The arm-conditioned projection is this step's observation path; the ablation turns its masking off, and
        # keeps the segmentation only where the goal's location is wanted (``locate_goal``).
        segmented = use_projection or locate_goal
        projection = ArmProjection(make_segmenter(segmenter, **(segmenter_options or {}))) if segmented else None
        self.builder = ArmObservationBuilder(VoxelGrid(tuple(cfg.bounds), cfg.voxel_size), projection,
                                             mask_voxels=use_projection, points=prior.cloud_points,
                                             voxels=prior.observation == "voxels",
                                             goal_objects=goal_objects and segmented)

    def text(self, instruction: str, features: np.ndarray | None = None) -> torch.Tensor:
        """The prior's instruction embedding (batch of one) for an episode given ``instruction``, for an arm that
        observes ``features`` (``chooser_features``; needed with an instruction chooser)."""
        return self.embedding(self.prior_texts([instruction], None if features is None else np.atleast_2d(features))[0])

    def embedding(self, text: str) -> torch.Tensor:
        """The prior's embedding (batch of one) of ``text``, encoded once per step object."""
        if text not in self._embeddings:
            self._embeddings[text] = torch.as_tensor(self.text_encoder.encode([text]))
        return self._embeddings[text]

    def prior_texts(self, instructions: list[str], features: np.ndarray | None = None) -> list[str]:
        """What the prior reads for each of ``instructions``, the arm observing each row of ``features``."""
        if self.instruction_chooser is None:
            return [self.prior_instruction or t for t in instructions]
        if features is None or len(features) != len(instructions):
            raise ValueError("a prior step with an instruction chooser needs each arm's features (chooser_features) "
                             "beside its instruction")
        return [chosen or t for chosen, t in zip(self.instruction_chooser.choose(features), instructions,
                                                 strict=True)]

    def run(self, obs: KeyframeObservation) -> dict[str, ArmStep]:
        with policy_threads():  # the same bits whatever the process's thread count (core/threads.py)
            per_arm = self.builder.build(obs)
            frames = arm_frames(obs)
            arms = obs.scene.arm_names
            asked, proprio, inputs = {}, {}, []
            for arm in arms:  # text embeddings are cached on this object: encoded here, not on the arms' threads
                features = (chooser_features(per_arm[arm].goal, per_arm[arm].proprio, per_arm[arm].other_proprio)
                            if self.instruction_chooser is not None else None)
                asked[arm] = self.prior_texts([obs.instruction], features)[0]
                text = self.embedding(asked[arm])
                proprio[arm] = self.prior.arm_proprio(per_arm[arm].proprio, obs.keyframe_index)
                scene = self.prior.observation_input(per_arm[arm].voxels, per_arm[arm].points)
                inputs.append((torch.as_tensor(scene)[None], torch.as_tensor(proprio[arm])[None], text))
            outs = map_arms(self._predict, inputs, concurrent=self.prior.concurrent_predict)
        return {arm: ArmStep(frames[arm], proprio[arm], per_arm[arm].other_proprio, out, per_arm[arm].goal,
                             "" if asked[arm] == obs.instruction else asked[arm])
                for arm, out in zip(arms, outs, strict=True)}

    def _predict(self, inputs: tuple[torch.Tensor, torch.Tensor, torch.Tensor]) -> PriorOutput:
        out = self.prior.predict(*inputs)
        if self.proposal_features:
            out.proposal_features = self.prior.proposal_features(*inputs, out)
        return out


def world_action(frame: ArmFrame, position: np.ndarray, quat: np.ndarray, gripper_open: float,
                 ignore_collisions: float) -> np.ndarray:
    """An arm-frame action as the env's world-frame row, clamped into the reachable workspace."""
    pos, q = frame.pose_to_world(position, quat)
    pos = np.clip(pos, WORKSPACE_LOW + 1e-3, WORKSPACE_HIGH - 1e-3)
    return np.r_[pos, q, float(gripper_open > 0.5), float(ignore_collisions > 0.5)].astype(np.float32)
