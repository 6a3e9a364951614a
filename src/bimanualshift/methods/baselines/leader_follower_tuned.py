"""Baselines: PerAct-LF, DP-LF and RVT-LF, the leader-follower pair of PerAct² fine-tuned from a single-arm prior
(the PerAct-style one, the Diffusion Policy one or the RVT-style one).

Two networks start from the same single-arm checkpoint and are fine-tuned (every weight) on the bimanual demos,
on the global scene. The right arm leads; the left arm follows and conditions on the leader's action (its
position, orientation and gripper in the follower's frame), given as extra proprioception whose input weights
start at zero, so fine-tuning starts from the prior's behaviour. During training the follower sees the expert
leader's action (teacher forcing); at test time it sees the leader network's prediction.
"""

from __future__ import annotations

import json
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

LEADER, FOLLOWER = "right", "left"
LEADER_ACTION = 8  # position, quaternion, gripper


def action_in_frame(world_row: np.ndarray, frame: ArmFrame) -> np.ndarray:
    """A world-frame action row (position, quaternion, gripper, ...) as (8,) in ``frame``."""
    pos, quat = frame.pose_to_arm(world_row[:3], world_row[3:7])
    return np.r_[pos, quat, world_row[7]].astype(np.float32)


def leader_extras(samples: ArmSamples, frames: list[dict[str, ArmFrame]]) -> np.ndarray:
    """Per sample, the leader's expert action at the same keyframe in the sample arm's frame (zeros for the
    leader's own samples, which the follower network never sees)."""
    where = {(int(e), a, int(k)): i for i, (e, a, k) in enumerate(zip(samples.episode, samples.arm, samples.keyframe))}
    out = np.zeros((len(samples), LEADER_ACTION), np.float32)
    for i, (e, arm, k) in enumerate(zip(samples.episode, samples.arm, samples.keyframe)):
        j = where.get((int(e), LEADER, int(k)))
        if arm == LEADER or j is None:
            continue
        pos, quat = frames[int(e)][LEADER].pose_to_world(samples.action_pos[j], samples.action_quat[j])
        out[i] = action_in_frame(np.r_[pos, quat, samples.gripper_open[j]], frames[int(e)][arm])
    return out


LEADER_SPEC = VoxelNetworkSpec("lf_leader", arms=(LEADER,), extra_dim=0, init_from_prior=True)
FOLLOWER_SPEC = VoxelNetworkSpec("lf_follower", arms=(FOLLOWER,), extra_dim=LEADER_ACTION,
                                 extra_proprio=leader_extras, extra_poses=(0,), init_from_prior=True)


DP_LEADER_SPEC = replace(LEADER_SPEC, name="dp_lf_leader", kind="diffusion")
DP_FOLLOWER_SPEC = replace(FOLLOWER_SPEC, name="dp_lf_follower", kind="diffusion")
RVT_LEADER_SPEC = replace(LEADER_SPEC, name="rvt_lf_leader", kind="rvt")
RVT_FOLLOWER_SPEC = replace(FOLLOWER_SPEC, name="rvt_lf_follower", kind="rvt")
PAIR_SPECS = {"peract": (LEADER_SPEC, FOLLOWER_SPEC), "diffusion": (DP_LEADER_SPEC, DP_FOLLOWER_SPEC),
              "rvt": (RVT_LEADER_SPEC, RVT_FOLLOWER_SPEC)}


class LeaderFollowerPolicy:
    name = "peract_lf"

    def __init__(self, pair: str | Path, text_encoder: TextEncoder) -> None:
        path = Path(pair) / "pair.json"
        if not path.is_file():
            raise FileNotFoundError(f"no leader-follower pair at {pair} (pair.json missing); train it with the "
                                    "benchmark's peract_lf method")
        spec = json.loads(path.read_text())
        self.leader = VoxelNetworkRunner(spec["leader"], text_encoder, OWN_PROPRIO)
        self.follower = VoxelNetworkRunner(spec["follower"], text_encoder, OWN_PROPRIO + LEADER_ACTION)

    def reset(self) -> None:
        pass

    @torch.no_grad()
    def act(self, obs: KeyframeObservation) -> np.ndarray:
        arms = obs.scene.arm_names
        if set(arms) != {LEADER, FOLLOWER}:
            raise ValueError(f"a leader-follower pair drives arms {LEADER} and {FOLLOWER}, not {arms}")
        view = self.leader.view(obs)
        lead = self.leader.act(view, LEADER, np.zeros(0, np.float32))
        follow = self.follower.act(view, FOLLOWER, action_in_frame(lead, view.frames[FOLLOWER]))
        rows = {LEADER: lead, FOLLOWER: follow}
        return np.stack([rows[a] for a in arms])


class DiffusionLeaderFollowerPolicy(LeaderFollowerPolicy):
    name = "dp_lf"


class RVTLeaderFollowerPolicy(LeaderFollowerPolicy):
    name = "rvt_lf"
