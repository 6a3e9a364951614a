"""Per-arm training samples built from stored episodes: arm-frame voxels, proprio, instruction, targets."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from bimanualshift.data.episode import read_episode
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.geometry.frames import ArmFrame, quat_to_euler_bins
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.observation import ArmObservationBuilder


@dataclass
class ArmSamples:
    """N samples of one arm's view; actions are targets in that arm's base frame."""

    voxels: np.ndarray  # (N, 4, S, S, S) float16
    proprio: np.ndarray  # (N, 9): arm-frame proprio (8) + keyframe fraction
    instructions: list[str]
    action_pos: np.ndarray  # (N, 3) arm frame
    action_quat: np.ndarray  # (N, 4) arm frame
    gripper_open: np.ndarray  # (N,) int64
    ignore_collisions: np.ndarray  # (N,) int64
    episode: np.ndarray  # (N,) index of the source episode
    keyframe: np.ndarray  # (N,)
    arm: list[str]
    other_proprio: np.ndarray  # (N, 8) the other arm's proprio in this arm's frame (zeros if single-arm)

    def __len__(self) -> int:
        return len(self.instructions)


def build_arm_samples(paths: list[Path], builder: ArmObservationBuilder, max_keyframes: int = 25,
                      desc: str = "voxelise") -> ArmSamples:
    rows: dict[str, list] = {k: [] for k in ArmSamples.__dataclass_fields__}
    for e, path in enumerate(tqdm(paths, desc=desc, unit="ep")):
        episode = read_episode(path)
        for k in range(episode.num_keyframes):
            obs = KeyframeObservation.from_episode(episode, k)
            per_arm = builder.build(obs)
            for i, arm in enumerate(episode.arm_names):
                frame = ArmFrame(tuple(episode.arm_bases[arm]))
                act = episode["actions"][k, i]
                pos, quat = frame.pose_to_arm(act[:3], act[3:7])
                rows["voxels"].append(per_arm[arm].voxels.astype(np.float16))
                rows["proprio"].append(np.r_[per_arm[arm].proprio, k / max_keyframes].astype(np.float32))
                rows["instructions"].append(episode.instruction)
                rows["action_pos"].append(pos.astype(np.float32))
                rows["action_quat"].append(quat.astype(np.float32))
                rows["gripper_open"].append(int(act[7] > 0.5))
                rows["ignore_collisions"].append(int(act[8] > 0.5))
                rows["episode"].append(e)
                rows["keyframe"].append(k)
                rows["arm"].append(arm)
                rows["other_proprio"].append(per_arm[arm].other_proprio)
    return ArmSamples(**{k: (v if k in ("instructions", "arm") else np.asarray(v)) for k, v in rows.items()})


def discrete_targets(samples: ArmSamples, grid: VoxelGrid, bin_degrees: float) -> dict[str, np.ndarray]:
    idx = grid.point_to_index(samples.action_pos)
    s = grid.size
    return {
        "translation_index": (idx[:, 0] * s + idx[:, 1]) * s + idx[:, 2],
        "rotation_bins": np.stack([quat_to_euler_bins(q, bin_degrees) for q in samples.action_quat]),
        "gripper_open": samples.gripper_open,
        "ignore_collisions": samples.ignore_collisions,
    }
