"""Baseline: the same frozen single-arm prior drives each arm on its own, with no residual.

The floor every bimanual method built on the prior must clear: no fine-tuning, no conditioning of one arm on the
other (the fine-tuned leader-follower pair is ``baselines/leader_follower_tuned.py``, PerAct-LF and DP-LF). On a
single-arm task it is simply the prior itself, reported under the name "prior".
"""

from __future__ import annotations

import numpy as np

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.encoders.text import TextEncoder
from bimanualshift.methods.prior_step import FrozenPriorStep, world_action
from bimanualshift.priors.base import UnimanualPrior


class FrozenPriorPerArm:
    def __init__(self, prior_step: FrozenPriorStep, name: str = "frozen_prior_per_arm") -> None:
        self.prior_step = prior_step
        self.name = name

    @staticmethod
    def from_pretrained(prior: str, text_encoder: TextEncoder, name: str = "frozen_prior_per_arm",
                        use_projection: bool = False, segmenter: str = "simulator") -> FrozenPriorPerArm:
        """The baseline sees the global scene: no arm-conditioned projection, no residual. With
        ``use_projection`` it is the "without residual modulation" ablation: the projection, but no residual."""
        return FrozenPriorPerArm(FrozenPriorStep(UnimanualPrior.from_pretrained(prior), text_encoder,
                                                  use_projection=use_projection, segmenter=segmenter), name)

    def reset(self) -> None:
        self._log: list[dict] = []
        self._chunk: np.ndarray | None = None

    def act(self, obs: KeyframeObservation) -> np.ndarray:
        steps = self.prior_step.run(obs)
        rows, chunks = [], []
        for arm in obs.scene.arm_names:
            p = steps[arm].prior
            rows.append(world_action(steps[arm].frame, p.position[0].numpy(), p.quat[0].numpy(),
                                     float(p.gripper_open[0]), float(p.ignore_collisions[0])))
            if p.chunk is not None:  # the keyframes after the first in the same arm frame, flags as the first's
                chunks.append(np.stack([rows[-1]] + [
                    world_action(steps[arm].frame, step[:3], step[3:7], float(step[7]), float(p.ignore_collisions[0]))
                    for step in p.chunk[0, 1:].numpy()]))
        self._chunk = np.stack(chunks) if len(chunks) == len(rows) else None
        self._log = [{"arm": arm, "prior": np.round(row[:7], 4).tolist(),
                      "prior_gripper_open": round(float(steps[arm].prior.gripper_open[0]), 4)}
                     for arm, row in zip(obs.scene.arm_names, rows)]
        return np.stack(rows)

    def action_chunk(self) -> np.ndarray | None:
        """(arms, H, 9) world rows of the last ``act``: the prior's H planned keyframes (the first is the action
        executed) where it predicts a chunk (Diffusion Policy, ACT), else None. A client may run them open loop
        (`deploy --chunk-steps`); the benchmark executes only the first."""
        return getattr(self, "_chunk", None)

    def keyframe_log(self) -> dict:
        """Per arm the prior's world-frame action: here it is also the executed one."""
        return {"arms": getattr(self, "_log", [])}
