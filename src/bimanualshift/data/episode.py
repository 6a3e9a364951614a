"""On-disk demonstration format: one compressed HDF5 file per episode.

Layout of ``<task>/episode_<seed>.h5`` (K keyframes, C cameras, A arms, H x W images)::

    attrs   format="bimanualshift-episode", version, task, seed, instruction, success,
            arm_names, camera_names, instance_names, class_names, goal_nouns, arm_bases (JSON),
            instance_colours (JSON, optional: instance name -> painted colour names; absent before 2026-12)
    rgb          (K, C, H, W, 3) uint8    colour images, row 0 at the top
    depth        (K, C, H, W)    float32  metres along the optical axis
    instance     (K, C, H, W)    int16    index into attrs["instance_names"] (0 = background)
    class        (K, C, H, W)    int16    index into attrs["class_names"]
    intrinsics   (K, C, 3, 3)    float64  pinhole K
    extrinsics   (K, C, 4, 4)    float64  camera-to-world, OpenCV optical frame
    proprio      (K, A, 8)       float32  end-effector xyz, quaternion xyzw, gripper open (world frame)
    actions      (K, A, 9)       float32  the keyframe reached from observation k: xyz, quaternion xyzw,
                                          gripper open, ignore collisions (world frame)
    dense/       optional, every 50 ms control step of the executed motion (T steps):
      joint_positions  (T, A, J) float32, joint_velocities (T, A, J) float32 (J: the arm's joints, 7 on a Panda,
                       6 on a UR5e),
      eef_pose         (T, A, 7) float32  xyz + quaternion xyzw,  gripper_open (T, A) float32

Observation k is what the cameras saw before keyframe action k was executed. Files are written to a
temporary name and renamed, so a crash never leaves a half-written episode under the final name.
No pickles: every field is a plain array or a JSON string.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from bimanualshift.utils.hub import is_hub_ref, resolve_local
from bimanualshift.utils.io import atomic_writer

FORMAT_NAME = "bimanualshift-episode"
FORMAT_VERSION = 1
JSON_ATTRS = ("arm_names", "camera_names", "instance_names", "class_names", "goal_nouns", "arm_bases")
OPTIONAL_JSON_ATTRS = ("instance_colours",)  # files written without them still read (as empty)
SCALAR_ATTRS = ("task", "seed", "instruction", "success")
# name -> (dtype, shape after the keyframe axis, with symbols C, A, H, W)
ARRAYS: dict[str, tuple[str, tuple[str | int, ...]]] = {
    "rgb": ("uint8", ("C", "H", "W", 3)),
    "depth": ("float32", ("C", "H", "W")),
    "instance": ("int16", ("C", "H", "W")),
    "class": ("int16", ("C", "H", "W")),
    "intrinsics": ("float64", ("C", 3, 3)),
    "extrinsics": ("float64", ("C", 4, 4)),
    "proprio": ("float32", ("A", 8)),
    "actions": ("float32", ("A", 9)),
}

DENSE_ARRAYS: dict[str, tuple[int | None, ...]] = {  # name -> shape after the (T, A) axes (None: the arm's joints)
    "joint_positions": (None,), "joint_velocities": (None,), "eef_pose": (7,), "gripper_open": (),
}


class EpisodeFormatError(ValueError):
    """An episode file that is missing, truncated or does not follow the documented schema."""


@dataclass
class Episode:
    task: str
    seed: int
    instruction: str
    success: bool
    arm_names: list[str]
    camera_names: list[str]
    instance_names: list[str]
    class_names: list[str]
    goal_nouns: list[str]
    arm_bases: dict[str, list[float]]
    arrays: dict[str, np.ndarray] = field(default_factory=dict)
    instance_colours: dict[str, list[str]] = field(default_factory=dict)
    dense: dict[str, np.ndarray] | None = None  # the control-step trajectory, when it was recorded

    @property
    def num_keyframes(self) -> int:
        return int(self.arrays["actions"].shape[0])

    def __getitem__(self, key: str) -> np.ndarray:
        return self.arrays[key]


def episode_path(root: str | Path, task: str, seed: int) -> Path:
    return Path(root) / task / f"episode_{seed:06d}.h5"


def write_episode(path: str | Path, episode: Episode) -> Path:
    path = Path(path)
    _validate_arrays(episode.arrays, len(episode.camera_names), len(episode.arm_names), str(path))
    if episode.dense is not None:
        _validate_dense(episode.dense, len(episode.arm_names), str(path))
    with atomic_writer(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs["format"] = FORMAT_NAME
        f.attrs["version"] = FORMAT_VERSION
        for key in SCALAR_ATTRS:
            f.attrs[key] = getattr(episode, key)
        for key in (*JSON_ATTRS, *OPTIONAL_JSON_ATTRS):
            f.attrs[key] = json.dumps(getattr(episode, key))
        for name, array in episode.arrays.items():
            f.create_dataset(name, data=array, compression="gzip", compression_opts=4,
                             chunks=(1, *array.shape[1:]) if array.ndim > 1 else None)
        if episode.dense is not None:
            group = f.create_group("dense")
            for name, array in episode.dense.items():
                group.create_dataset(name, data=array, compression="gzip", compression_opts=4)
    return path


def read_episode(path: str | Path) -> Episode:
    path = Path(path)
    if not path.is_file():
        raise EpisodeFormatError(f"{path}: no such episode file (collect demos with `bimanualshift collect`)")
    try:
        with h5py.File(path, "r") as f:
            attrs = dict(f.attrs)
            if attrs.get("format") != FORMAT_NAME:
                raise EpisodeFormatError(f"{path}: not a {FORMAT_NAME} file (attrs['format']={attrs.get('format')!r})")
            if int(attrs.get("version", -1)) != FORMAT_VERSION:
                raise EpisodeFormatError(
                    f"{path}: format version {attrs.get('version')} but this bimanualshift reads version "
                    f"{FORMAT_VERSION}; re-collect the demos with this version"
                )
            missing = [k for k in (*SCALAR_ATTRS, *JSON_ATTRS) if k not in attrs]
            missing += [k for k in ARRAYS if k not in f]
            if missing:
                raise EpisodeFormatError(
                    f"{path}: missing fields {missing}; the file is incomplete or from another tool"
                )
            arrays = {k: f[k][()] for k in ARRAYS}
            dense = {k: f["dense"][k][()] for k in DENSE_ARRAYS} if "dense" in f else None
    except EpisodeFormatError:
        raise
    except (OSError, KeyError, ValueError) as exc:
        raise EpisodeFormatError(f"{path}: cannot be read as HDF5 ({exc}); the file is probably truncated or "
                                 "corrupt; delete it and collect it again") from exc
    meta: dict[str, Any] = {k: json.loads(attrs[k]) for k in (*JSON_ATTRS, *OPTIONAL_JSON_ATTRS) if k in attrs}
    episode = Episode(
        task=str(attrs["task"]), seed=int(attrs["seed"]), instruction=str(attrs["instruction"]),
        success=bool(attrs["success"]), arrays=arrays, dense=dense, **meta,
    )
    _validate_arrays(arrays, len(episode.camera_names), len(episode.arm_names), str(path))
    if dense is not None:
        _validate_dense(dense, len(episode.arm_names), str(path))
    return episode


def _validate_arrays(arrays: dict[str, np.ndarray], n_cameras: int, n_arms: int, where: str) -> None:
    missing = sorted(set(ARRAYS) - set(arrays))
    if missing:
        raise EpisodeFormatError(f"{where}: missing arrays {missing}")
    k = arrays["actions"].shape[0]
    if k == 0:
        raise EpisodeFormatError(f"{where}: episode has no keyframes")
    h, w = arrays["depth"].shape[-2:]
    sizes = {"C": n_cameras, "A": n_arms, "H": h, "W": w}
    for name, (dtype, shape) in ARRAYS.items():
        expected = (k, *(sizes[s] if isinstance(s, str) else s for s in shape))
        got = arrays[name]
        if got.shape != expected:
            raise EpisodeFormatError(f"{where}: array {name!r} has shape {got.shape}, expected {expected} "
                                     f"({k} keyframes, {n_cameras} cameras, {n_arms} arms, {h}x{w} images)")
        if got.dtype != np.dtype(dtype):
            raise EpisodeFormatError(f"{where}: array {name!r} has dtype {got.dtype}, expected {dtype}")
    if not np.all(np.isfinite(arrays["actions"])):
        raise EpisodeFormatError(f"{where}: actions contain NaN or infinite values")


def _validate_dense(dense: dict[str, np.ndarray], n_arms: int, where: str) -> None:
    if set(dense) != set(DENSE_ARRAYS):
        raise EpisodeFormatError(f"{where}: dense trajectory has fields {sorted(dense)}, "
                                 f"expected {sorted(DENSE_ARRAYS)}")
    steps = dense["gripper_open"].shape[0]
    joints = dense["joint_positions"].shape[-1] if dense["joint_positions"].ndim == 3 else -1
    if not 1 <= joints <= 16:
        raise EpisodeFormatError(f"{where}: dense['joint_positions'] has shape {dense['joint_positions'].shape}, "
                                 f"expected ({steps}, {n_arms}, joints)")
    for name, tail in DENSE_ARRAYS.items():
        want = (steps, n_arms, *(joints if d is None else d for d in tail))
        if dense[name].shape != want:
            raise EpisodeFormatError(f"{where}: dense[{name!r}] has shape {dense[name].shape}, expected "
                                     f"{want} ({steps} control steps, {n_arms} arms, {joints} joints)")


EPISODE_GLOB = "episode_*.h5"


def list_episodes(root: str | Path, task: str) -> list[Path]:
    """``root`` is a folder or an ``hf://datasets/...`` reference (its cached snapshot)."""
    if is_hub_ref(root):
        local = resolve_local(root, "dataset")
        if (local / "meta" / "info.json").is_file():
            raise ValueError(f"{root} is a LeRobot dataset: turn it into episodes once with `bimanualshift "
                             f"import-lerobot {root} --out data/NAME`, then pass data/NAME")
        root = local
    return sorted((Path(root) / task).glob(EPISODE_GLOB))


def episode_is_current(path: str | Path) -> bool:
    """True if ``path`` is a readable episode file carrying every field this version writes (a cache of demos
    collected before a field was added is collected again rather than silently used without it)."""
    try:
        with h5py.File(path, "r") as f:
            return f.attrs.get("format") == FORMAT_NAME and all(k in f.attrs for k in OPTIONAL_JSON_ATTRS)
    except (OSError, KeyError, ValueError):
        return False
