"""Baseline: the same frozen single-arm prior drives each arm on its own, with no residual.

This is the leader-follower baseline in its simplest form (no fine-tuning, no conditioning of one arm
on the other); on a single-arm task it is simply the prior itself, reported under the name "prior".
"""

from __future__ import annotations

import numpy as np

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.methods.stages import FrozenPriorStage, world_action


class FrozenPriorPerArm:
    def __init__(self, stage: FrozenPriorStage, name: str = "leader_follower") -> None:
        self.stage = stage
        self.name = name

    def reset(self) -> None:
        pass

    def act(self, obs: KeyframeObservation) -> np.ndarray:
        steps = self.stage.run(obs)
        rows = []
        for arm in obs.scene.arm_names:
            p = steps[arm].prior
            rows.append(world_action(steps[arm].frame, p.position[0].numpy(), p.quat[0].numpy(),
                                     float(p.gripper_open[0]), float(p.ignore_collisions[0])))
        return np.stack(rows)
