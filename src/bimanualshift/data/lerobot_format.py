"""Episodes as a LeRobot v3.0 dataset and back, written with pyarrow and PyAV (lerobot itself needs another
Python and torch).

Layout (the paths and keys of ``lerobot.datasets.utils``: ``INFO_PATH``, ``DEFAULT_DATA_PATH``,
``DEFAULT_VIDEO_PATH``, ``DEFAULT_EPISODES_PATH``, ``DEFAULT_TASKS_PATH``, ``STATS_PATH``)::

    meta/info.json                      codebase_version "v3.0", fps, features, path templates, totals
    meta/stats.json                     per numeric feature: min, max, mean, std, count
    meta/tasks.parquet                  task_index per instruction (the instruction is the index)
    meta/episodes/chunk-000/file-000.parquet   per episode: length, tasks, data/video file and offsets
    data/chunk-000/file-000.parquet     one row per frame
    videos/observation.images.<cam>/chunk-000/file-000.mp4   RGB, all episodes of a camera back to back

One frame is one keyframe observation of a bimanualshift episode (``fps`` = 1: keyframes are not evenly
spaced in time; ``timestamp`` is the keyframe index). Features:

    observation.images.<cam>      video (H, W, 3)       RGB (lossy: AV1, as LeRobot encodes)
    observation.depth.<cam>       float32 (H, W)        metres, exact (parquet, never video)
    observation.instance.<cam>    int16 (H, W)          optional, simulator instance ids
    observation.class.<cam>       int16 (H, W)          optional, simulator class ids
    observation.intrinsics.<cam>  float64 (3, 3)        calibration (per frame: wrist cameras move)
    observation.extrinsics.<cam>  float64 (4, 4)        camera-to-world, OpenCV optical axes
    observation.state             float32 (A * 8)       per arm x y z qx qy qz qw gripper_open (world frame)
    action                        float32 (A * 9)       per arm the next keyframe: pose, gripper, ignore_collisions

``info.json`` also holds ``bimanualshift`` (arm and camera names) and each episode's row its task name, seed,
success, arm bases, segmentation names and goal nouns (columns ``bimanualshift/...``).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from bimanualshift.data.episode import Episode
from bimanualshift.data.kinematics import KinematicsModel
from bimanualshift.utils.io import atomic_write_json

CODEBASE_VERSION = "v3.0"
CHUNK_FILE = "chunk-{chunk_index:03d}/file-{file_index:03d}"
DATA_PATH = "data/" + CHUNK_FILE + ".parquet"
VIDEO_PATH = "videos/{video_key}/" + CHUNK_FILE + ".mp4"
EPISODES_PATH = "meta/episodes/" + CHUNK_FILE + ".parquet"
TASKS_PATH = "meta/tasks.parquet"
INFO_PATH, STATS_PATH = "meta/info.json", "meta/stats.json"
FPS = 1
VIDEO_CODEC, VIDEO_CRF = "libsvtav1", 30
STATE_FIELDS = ("x", "y", "z", "qx", "qy", "qz", "qw", "gripper_open")
ACTION_FIELDS = (*STATE_FIELDS, "ignore_collisions")
META_PREFIX = "bimanualshift/"


class LeRobotFormatError(ValueError):
    """A dataset that is not LeRobot v3.0, or lacks what the method needs (the message lists what)."""


def _feature(dtype: str, shape: tuple[int, ...], names: list[str] | None = None) -> dict[str, Any]:
    return {"dtype": dtype, "shape": list(shape), "names": names}


def _encode_video(frames: np.ndarray, path: Path) -> None:
    import os

    import av

    os.environ.setdefault("SVT_LOG", "1")  # the AV1 encoder's banner only at errors
    path.parent.mkdir(parents=True, exist_ok=True)
    h, w = frames.shape[1:3]
    with av.open(str(path), "w") as container:
        stream = container.add_stream(VIDEO_CODEC, rate=FPS, options={"crf": str(VIDEO_CRF), "g": "2"})
        stream.width, stream.height, stream.pix_fmt = w, h, "yuv420p"
        for frame in frames:
            for packet in stream.encode(av.VideoFrame.from_ndarray(np.ascontiguousarray(frame), format="rgb24")):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)


def _decode_video(path: Path) -> np.ndarray:
    import av

    with av.open(str(path)) as container:
        return np.stack([f.to_ndarray(format="rgb24") for f in container.decode(video=0)])


def _stats(values: np.ndarray) -> dict[str, list]:
    axis = 0
    v = values.astype(np.float64).reshape(len(values), -1) if values.ndim > 1 else values[:, None].astype(np.float64)
    return {"min": v.min(axis).tolist(), "max": v.max(axis).tolist(), "mean": v.mean(axis).tolist(),
            "std": v.std(axis).tolist(), "count": [int(len(values))]}


def export_lerobot(episodes: list[Episode], out: str | Path, robot_type: str = "bimanual_panda",
                   overwrite: bool = False) -> Path:
    """Write ``episodes`` (same cameras, arms and image size) as one LeRobot v3.0 dataset in ``out``."""
    out = Path(out)
    if not episodes:
        raise ValueError("no episodes to export")
    if out.exists() and any(out.iterdir()):
        if not overwrite:
            raise FileExistsError(f"{out} is not empty: choose another folder or pass --overwrite")
        shutil.rmtree(out)
    first = episodes[0]
    cams, arms = list(first.camera_names), list(first.arm_names)
    h, w = first.arrays["rgb"].shape[2:4]
    for ep in episodes:
        if ep.camera_names != cams or ep.arm_names != arms or ep.arrays["rgb"].shape[2:4] != (h, w):
            raise ValueError(f"episode {ep.task} seed {ep.seed} has other cameras, arms or image size than the "
                             "first: export them to separate datasets")
    features: dict[str, dict[str, Any]] = {}
    for cam in cams:
        features[f"observation.images.{cam}"] = {
            **_feature("video", (h, w, 3), ["height", "width", "channels"]),
            "info": {"video.height": h, "video.width": w, "video.codec": "av1", "video.pix_fmt": "yuv420p",
                     "video.is_depth_map": False, "video.fps": FPS, "video.channels": 3, "has_audio": False}}
        features[f"observation.depth.{cam}"] = _feature("float32", (h, w), ["height", "width"])
        features[f"observation.instance.{cam}"] = _feature("int16", (h, w), ["height", "width"])
        features[f"observation.class.{cam}"] = _feature("int16", (h, w), ["height", "width"])
        features[f"observation.intrinsics.{cam}"] = _feature("float64", (3, 3), None)
        features[f"observation.extrinsics.{cam}"] = _feature("float64", (4, 4), None)
    features["observation.state"] = _feature("float32", (8 * len(arms),),
                                             [f"{a}_{f}" for a in arms for f in STATE_FIELDS])
    features["action"] = _feature("float32", (9 * len(arms),), [f"{a}_{f}" for a in arms for f in ACTION_FIELDS])
    for key, dtype in (("timestamp", "float32"), ("frame_index", "int64"), ("episode_index", "int64"),
                       ("index", "int64"), ("task_index", "int64")):
        features[key] = _feature(dtype, (1,), None)

    tasks: dict[str, int] = {}
    columns: dict[str, list] = {k: [] for k in features if features[k]["dtype"] != "video"}
    episode_rows: list[dict[str, Any]] = []
    rgb_per_cam: dict[str, list[np.ndarray]] = {cam: [] for cam in cams}
    index = 0
    for e, ep in enumerate(episodes):
        a = ep.arrays
        k = ep.num_keyframes
        task_index = tasks.setdefault(ep.instruction, len(tasks))
        for i in range(k):
            for c, cam in enumerate(cams):
                columns[f"observation.depth.{cam}"].append(a["depth"][i, c])
                columns[f"observation.instance.{cam}"].append(a["instance"][i, c])
                columns[f"observation.class.{cam}"].append(a["class"][i, c])
                columns[f"observation.intrinsics.{cam}"].append(a["intrinsics"][i, c])
                columns[f"observation.extrinsics.{cam}"].append(a["extrinsics"][i, c])
            columns["observation.state"].append(a["proprio"][i].reshape(-1))
            columns["action"].append(a["actions"][i].reshape(-1))
            columns["timestamp"].append(np.float32(i / FPS))
            columns["frame_index"].append(i)
            columns["episode_index"].append(e)
            columns["index"].append(index + i)
            columns["task_index"].append(task_index)
        start_frame = sum(len(x) for x in rgb_per_cam[cams[0]])
        for c, cam in enumerate(cams):
            rgb_per_cam[cam].append(a["rgb"][:, c])
        row: dict[str, Any] = {
            "episode_index": e, "tasks": [ep.instruction], "length": k,
            "data/chunk_index": 0, "data/file_index": 0, "dataset_from_index": index, "dataset_to_index": index + k,
            "meta/episodes/chunk_index": 0, "meta/episodes/file_index": 0,
            META_PREFIX + "task": ep.task, META_PREFIX + "seed": ep.seed, META_PREFIX + "success": ep.success,
            META_PREFIX + "arm_bases": json.dumps(ep.arm_bases), META_PREFIX + "instance_names":
                json.dumps(ep.instance_names), META_PREFIX + "class_names": json.dumps(ep.class_names),
            META_PREFIX + "goal_nouns": json.dumps(ep.goal_nouns),
            META_PREFIX + "instance_colours": json.dumps(ep.instance_colours),
            META_PREFIX + "dense": json.dumps({n: v.tolist() for n, v in ep.dense.items()}) if ep.dense else "",
        }
        for cam in cams:
            key = f"observation.images.{cam}"
            row.update({f"videos/{key}/chunk_index": 0, f"videos/{key}/file_index": 0,
                        f"videos/{key}/from_timestamp": start_frame / FPS,
                        f"videos/{key}/to_timestamp": (start_frame + k) / FPS})
        episode_rows.append(row)
        index += k

    tmp = out.with_name(out.name + ".partial")
    if tmp.exists():
        shutil.rmtree(tmp)
    data_path = tmp / DATA_PATH.format(chunk_index=0, file_index=0)
    data_path.parent.mkdir(parents=True)
    table = {}
    for key, values in columns.items():
        arr = np.stack(values) if np.ndim(values[0]) else np.asarray(values)
        if arr.ndim > 1:  # fixed-size nested lists, as datasets' Array2D / Sequence columns store them
            flat = pa.array(arr.reshape(-1))
            for size in reversed(arr.shape[1:]):
                flat = pa.FixedSizeListArray.from_arrays(flat, size)
            table[key] = flat
        else:
            table[key] = pa.array(arr)
    pq.write_table(pa.table(table), data_path)
    for cam in cams:
        _encode_video(np.concatenate(rgb_per_cam[cam]),
                      tmp / VIDEO_PATH.format(video_key=f"observation.images.{cam}", chunk_index=0, file_index=0))
    stats: dict[str, dict[str, list]] = {}
    for key in ("observation.state", "action", "timestamp", "frame_index", "episode_index", "index", "task_index"):
        stats[key] = _stats(np.asarray(columns[key]))
    for cam in cams:  # one value over all pixels, as an image's stats are per channel
        depth = np.stack(columns[f"observation.depth.{cam}"]).astype(np.float64)
        stats[f"observation.depth.{cam}"] = {"min": [float(depth.min())], "max": [float(depth.max())],
                                             "mean": [float(depth.mean())], "std": [float(depth.std())],
                                             "count": [len(depth)]}
        pixels = np.concatenate(rgb_per_cam[cam]).reshape(-1, 3) / 255.0
        stats[f"observation.images.{cam}"] = {
            "min": pixels.min(0).reshape(3, 1, 1).tolist(), "max": pixels.max(0).reshape(3, 1, 1).tolist(),
            "mean": pixels.mean(0).reshape(3, 1, 1).tolist(), "std": pixels.std(0).reshape(3, 1, 1).tolist(),
            "count": [len(columns["index"])]}
    atomic_write_json(tmp / STATS_PATH, stats)
    import pandas as pd  # the tasks table is a DataFrame indexed by the task string, as lerobot writes it

    pd.DataFrame({"task_index": list(tasks.values())}, index=pd.Index(list(tasks), name="task")).to_parquet(
        tmp / TASKS_PATH)
    episodes_path = tmp / EPISODES_PATH.format(chunk_index=0, file_index=0)
    episodes_path.parent.mkdir(parents=True)
    pq.write_table(pa.Table.from_pylist(episode_rows), episodes_path)
    info = {"codebase_version": CODEBASE_VERSION, "robot_type": robot_type, "total_episodes": len(episodes),
            "total_frames": index, "total_tasks": len(tasks), "chunks_size": 1000, "data_files_size_in_mb": 100,
            "video_files_size_in_mb": 500, "fps": FPS, "splits": {"train": f"0:{len(episodes)}"},
            "data_path": DATA_PATH, "video_path": VIDEO_PATH, "features": features,
            "bimanualshift": {"arm_names": arms, "camera_names": cams,
                              "frames": "one frame per keyframe observation; timestamp = keyframe index"}}
    atomic_write_json(tmp / INFO_PATH, info)
    tmp.rename(out)
    return out


# What the method needs from a dataset, per camera and in all: (feature, why)
def missing_features(info: dict[str, Any]) -> list[str]:
    """The features the method needs that ``info`` lacks, each with why (empty: nothing missing)."""
    feats = info.get("features", {})
    cams = sorted(k.removeprefix("observation.images.") for k in feats if k.startswith("observation.images."))
    problems = []
    if not cams:
        problems.append("observation.images.<camera>: RGB images (the method sees the scene through cameras)")
    for cam in cams:
        if f"observation.depth.{cam}" not in feats:
            problems.append(f"observation.depth.{cam}: metric depth for camera {cam} (the projection back-projects "
                            "pixels into 3-D)")
        for kind, shape in (("intrinsics", "3x3"), ("extrinsics", "4x4 camera-to-world")):
            if f"observation.{kind}.{cam}" not in feats:
                problems.append(f"observation.{kind}.{cam}: the {shape} calibration of camera {cam} (or add it "
                                "from a `bimanualshift calibrate` file)")
    names = (feats.get("observation.state") or {}).get("names") or []
    if not any(str(n).endswith("_qw") for n in names) or not any(str(n).endswith("_gripper_open") for n in names):
        problems.append("observation.state with end-effector poses (per arm <arm>_x .. <arm>_qw, <arm>_gripper_open)"
                        f"; this dataset's state is {names[:8]}{'...' if len(names) > 8 else ''}: a joint-space "
                        "state needs a kinematics model (--kinematics MODEL.xml) to compute the poses")
    if "action" not in feats:
        problems.append("action: the next keyframe per arm")
    return problems


def _proprio(part: pa.Table, names: list[str], arms: list[str], kinematics: KinematicsModel | None
             ) -> np.ndarray:
    """(frames, arms, 8) poses and gripper openings of a joint-space state, by forward kinematics."""
    assert kinematics is not None
    state = _column(part, "observation.state", (len(names),), "float64")
    poses = kinematics.ee_poses(state, names, arms)
    grip = np.zeros((len(state), len(arms), 1), np.float32)
    for a, arm in enumerate(arms):
        if f"{arm}_gripper" not in names:
            raise LeRobotFormatError(f"the state has no {arm}_gripper value (1 open, 0 closed)")
        grip[:, a, 0] = state[:, names.index(f"{arm}_gripper")]
    return np.concatenate([poses, grip], axis=2)


def _column(table: pa.Table, key: str, shape: tuple[int, ...], dtype: str) -> np.ndarray:
    col = table.column(key).combine_chunks()
    while pa.types.is_fixed_size_list(col.type) or pa.types.is_list(col.type):
        col = col.flatten()
    return np.asarray(col.to_numpy(zero_copy_only=False), dtype).reshape(len(table), *shape)


def import_lerobot(root: str | Path, arm_bases: dict[str, list[float]] | None = None,
                   kinematics: KinematicsModel | None = None, arms: list[str] | None = None) -> list[Episode]:
    """A LeRobot v3.0 dataset written by ``export_lerobot`` (or with the same features) as episodes.
    ``arm_bases`` (a calibration's) is used where the dataset does not record them. A joint-space state
    (no end-effector poses) needs ``kinematics`` and the ``arms`` its state names start with; each arm's gripper
    opening is read from its ``<arm>_gripper`` state value (1 open, 0 closed)."""
    root = Path(root)
    info_path = root / INFO_PATH
    if not info_path.is_file():
        raise LeRobotFormatError(f"{root}: no {INFO_PATH}; not a LeRobot dataset folder")
    info = json.loads(info_path.read_text())
    if info.get("codebase_version") != CODEBASE_VERSION:
        raise LeRobotFormatError(f"{root}: LeRobot {info.get('codebase_version')} dataset; this reader takes "
                                 f"{CODEBASE_VERSION} (convert it with lerobot's v30 converter)")
    problems = missing_features(info)
    joint_space = any(p.startswith("observation.state") for p in problems)
    if joint_space and kinematics is not None:
        if not arms:
            raise LeRobotFormatError("a joint-space dataset needs the arm names its state names start with (--arms)")
        problems = [p for p in problems if not p.startswith("observation.state")]
    if problems:
        raise LeRobotFormatError(f"{root} lacks what BimanualShift needs:\n  - " + "\n  - ".join(problems))
    feats = info["features"]
    extra = info.get("bimanualshift", {})
    cams = extra.get("camera_names") or sorted(k.removeprefix("observation.images.") for k in feats
                                                if k.startswith("observation.images."))
    state_names = feats["observation.state"]["names"]
    arms = arms or extra.get("arm_names") or list(dict.fromkeys(n.rsplit("_", 1)[0] for n in state_names
                                                        if n.endswith("_x")))
    h, w = feats[f"observation.images.{cams[0]}"]["shape"][:2]
    episodes_meta = [row for p in sorted((root / "meta/episodes").glob("*/*.parquet"))
                     for row in pq.read_table(p).to_pylist()]
    if any(META_PREFIX + "arm_bases" not in row for row in episodes_meta) and not arm_bases:
        raise LeRobotFormatError(f"{root} does not record the arms' base positions (the projection's anchors): "
                                 "pass --calibration FILE from `bimanualshift calibrate`")
    data = pa.concat_tables([pq.read_table(p) for p in sorted((root / "data").glob("*/*.parquet"))])
    videos = {cam: {} for cam in cams}
    for row in episodes_meta:
        for cam in cams:
            key = f"observation.images.{cam}"
            path = root / info["video_path"].format(video_key=key, chunk_index=row[f"videos/{key}/chunk_index"],
                                                    file_index=row[f"videos/{key}/file_index"])
            if path not in videos[cam]:
                videos[cam][path] = _decode_video(path)
    episode_index = _column(data, "episode_index", (), "int64")
    out = []
    for row in episodes_meta:
        rows = np.flatnonzero(episode_index == row["episode_index"])
        part = data.take(pa.array(rows))
        k = len(rows)
        n_cam, n_arm = len(cams), len(arms)
        arrays: dict[str, np.ndarray] = {
            "rgb": np.zeros((k, n_cam, h, w, 3), np.uint8), "depth": np.zeros((k, n_cam, h, w), np.float32),
            "instance": np.zeros((k, n_cam, h, w), np.int16), "class": np.zeros((k, n_cam, h, w), np.int16),
            "intrinsics": np.zeros((k, n_cam, 3, 3)), "extrinsics": np.zeros((k, n_cam, 4, 4)),
            "proprio": _proprio(part, state_names, arms, kinematics) if joint_space else
            _column(part, "observation.state", (n_arm, 8), "float32"),
            "actions": _column(part, "action", (n_arm, 9), "float32")}
        for c, cam in enumerate(cams):
            key = f"observation.images.{cam}"
            path = root / info["video_path"].format(video_key=key, chunk_index=row[f"videos/{key}/chunk_index"],
                                                    file_index=row[f"videos/{key}/file_index"])
            start = int(round(row[f"videos/{key}/from_timestamp"] * info["fps"]))
            arrays["rgb"][:, c] = videos[cam][path][start:start + k]
            arrays["depth"][:, c] = _column(part, f"observation.depth.{cam}", (h, w), "float32")
            for name, feature in (("instance", "instance"), ("class", "class")):
                if f"observation.{feature}.{cam}" in feats:
                    arrays[name][:, c] = _column(part, f"observation.{feature}.{cam}", (h, w), "int16")
            arrays["intrinsics"][:, c] = _column(part, f"observation.intrinsics.{cam}", (3, 3), "float64")
            arrays["extrinsics"][:, c] = _column(part, f"observation.extrinsics.{cam}", (4, 4), "float64")
        meta = {k.removeprefix(META_PREFIX): v for k, v in row.items() if k.startswith(META_PREFIX)}
        dense = json.loads(meta["dense"]) if meta.get("dense") else None
        out.append(Episode(
            task=meta.get("task", "lerobot"), seed=int(meta.get("seed", row["episode_index"])),
            instruction=row["tasks"][0], success=bool(meta.get("success", True)), arm_names=arms,
            camera_names=cams, instance_names=json.loads(meta.get("instance_names", "[]")),
            class_names=json.loads(meta.get("class_names", "[]")), goal_nouns=json.loads(meta.get("goal_nouns", "[]")),
            arm_bases=json.loads(meta["arm_bases"]) if "arm_bases" in meta else dict(arm_bases or {}),
            instance_colours=json.loads(meta.get("instance_colours", "{}")),
            arrays=arrays, dense={n: np.asarray(v, np.float32) for n, v in dense.items()} if dense else None))
    return out
