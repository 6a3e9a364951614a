"""Per-arm training samples built from stored episodes: arm-frame voxels, proprio, instruction, targets."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from bimanualshift.data.episode import Episode, read_episode
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.perception.observation import ArmObservationBuilder


@dataclass
class ArmSamples:
    """N samples of one arm's view; actions are targets in that arm's base frame."""

    voxels: np.ndarray | None  # (N, 4, S, S, S) float16; None when the builder skips voxels (point-cloud priors)
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
    goal: np.ndarray | None = None  # (N, GOAL_GEOMETRY_DIM) the goal's location in the arm's frame
    # (N, P, 6) float16 the arm's point cloud (arm-frame xyz, rgb), padded to P by repeating points; None unless
    # the builder keeps clouds (``ArmObservationBuilder(points=P)``, for point-cloud priors)
    points: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.instructions)

    def first_episodes(self, count: int) -> ArmSamples:
        """The samples of the first ``count`` source episodes (all of them when there are fewer)."""
        keep = np.flatnonzero(self.episode < count)
        values = {}
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            values[name] = (None if value is None else [value[i] for i in keep] if isinstance(value, list)
                            else value[keep])
        return ArmSamples(**values)


def build_arm_samples(paths: list[Path], builder: ArmObservationBuilder, max_keyframes: int,
                      desc: str = "voxelise", transform: Callable[[Episode], Episode] | None = None) -> ArmSamples:
    """Every (keyframe, arm) of the episodes as one arm's sample; ``transform`` rewrites each episode first (a
    baseline that re-anchors the arms' frames, e.g. on a region of interest)."""
    rows: dict[str, list] = {k: [] for k in ArmSamples.__dataclass_fields__}
    for e, path in enumerate(tqdm(paths, desc=desc, unit="ep")):
        episode = read_episode(path)
        if transform is not None:
            episode = transform(episode)
        for k in range(episode.num_keyframes):
            obs = KeyframeObservation.from_episode(episode, k)
            per_arm = builder.build(obs)
            for i, arm in enumerate(episode.arm_names):
                frame = ArmFrame(tuple(episode.arm_bases[arm]))
                act = episode["actions"][k, i]
                pos, quat = frame.pose_to_arm(act[:3], act[3:7])
                if builder.voxels:
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
                rows["goal"].append(per_arm[arm].goal)
                if builder.points:
                    rows["points"].append(padded_cloud(per_arm[arm].points, builder.points).astype(np.float16))
    for key, kept in (("points", builder.points), ("voxels", builder.voxels)):
        if not kept:
            del rows[key]
    return ArmSamples(**{k: (v if k in ("instructions", "arm") else np.asarray(v)) for k, v in rows.items()},
                      **{k: None for k in ("points", "voxels") if k not in rows})


def padded_cloud(points: np.ndarray | None, size: int) -> np.ndarray:
    """(size, 6) a cloud of at most ``size`` points padded by repeating its points in order (a repeated point is
    drawn as itself); an empty cloud becomes points far outside any workspace, which nothing draws."""
    if points is None or len(points) == 0:
        return np.tile(np.array([[1e3, 1e3, 1e3, 0, 0, 0]], np.float32), (size, 1))
    points = points.astype(np.float32)
    return points[:size] if len(points) >= size else np.resize(points, (size, points.shape[1]))


def action_chunks(samples: ArmSamples, horizon: int) -> dict[str, np.ndarray]:
    """Per sample, its own keyframe action and the next ``horizon - 1`` of the same arm in the same episode
    (the last one repeated past the episode's end): position (N, H, 3), quat (N, H, 4), gripper_open and
    ignore_collisions (N, H) int64."""
    if horizon < 1:
        raise ValueError(f"the action horizon must be >= 1, got {horizon}")
    where = {(int(e), arm, int(k)): i for i, (e, arm, k) in enumerate(zip(samples.episode, samples.arm,
                                                                           samples.keyframe))}
    rows = np.empty((len(samples), horizon), dtype=np.int64)
    for i, (e, arm, k) in enumerate(zip(samples.episode, samples.arm, samples.keyframe)):
        j = i
        for h in range(horizon):
            j = where.get((int(e), arm, int(k) + h), j)
            rows[i, h] = j
    return {"position": samples.action_pos[rows], "quat": samples.action_quat[rows],
            "gripper_open": samples.gripper_open[rows], "ignore_collisions": samples.ignore_collisions[rows]}
