"""The policy server's messages, version ``SCHEMA_VERSION``: what a robot sends each keyframe, what it gets back.

Observation (a msgpack map, arrays as ``codec`` packs them)::

    schema_version  int           SCHEMA_VERSION
    episode_id      str           a new id (or keyframe 0) starts a new episode: the policy's state is reset
    keyframe        int >= 0      the keyframe's index in the episode
    instruction     str
    goal_nouns      [str]         optional: what the segmenter looks for (default: parsed from the instruction)
    cameras         {name: camera}, each camera:
        rgb         uint8 (H, W, 3)
        depth       float32 (H, W), metres along the optical axis
        intrinsics  float (3, 3)
        extrinsics  float (4, 4), camera-to-world (OpenCV axes: x right, y down, z forward)
        instance    int (H, W), optional: instance ids (the simulator sends them; index into instance_names)
        class       int (H, W), optional: class ids (index into class_names)
    instance_names  [str]         with instance maps
    class_names     [str]         with class maps
    instance_colours {str: [str]} optional, with instance maps: instance name -> its painted colour names (the
                                  simulator's; a colour prompt such as "navy button" is matched against them)
    arms            {name: arm}, each arm (world frame):
        pose        float (7,)    end effector x, y, z, qx, qy, qz, qw
        gripper_open float        1 open, 0 closed
        base        float (3,)    the arm's base position (the calibration's anchor for the projection)

Reply: ``schema_version``, ``episode_id``, ``keyframe``, ``actions`` {arm: {pose (7,), gripper_open,
ignore_collisions}}, ``action`` float32 (arms, 9) (the same rows, arms in the observation's order),
``chunk`` float32 (arms, k, 9) where the policy plans k keyframes ahead (``action_chunk()``),
``timing`` {decode_ms, infer_ms, server_ms}, ``diagnostics`` (the policy's keyframe log: prior and final
actions, holds, retrieval similarity).

A request that cannot be served gets a text frame (``error_frame``): JSON ``{"error": {"code", "field",
"expected", "got", "message"}, "schema_version"}``. openpi's client raises it as a ``RuntimeError``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from bimanualshift.core.goal_nouns import extract_goal_nouns
from bimanualshift.data.frames import KeyframeObservation, SceneInfo

SCHEMA_VERSION = 1
ACTION_WIDTH = 9  # x, y, z, qx, qy, qz, qw, gripper_open, ignore_collisions
MAX_CAMERAS, MAX_ARMS, MAX_SIDE, MAX_NAMES, MAX_TEXT = 16, 4, 4096, 4096, 4096


class SchemaError(ValueError):
    """A message that does not follow the schema: which field, what it should be, what came."""

    def __init__(self, field: str, expected: str, got: str, code: str = "bad_field") -> None:
        super().__init__(f"{field}: expected {expected}, got {got}")
        self.field, self.expected, self.got, self.code = field, expected, got, code

    def as_dict(self) -> dict[str, str]:
        return {"code": self.code, "field": self.field, "expected": self.expected, "got": self.got,
                "message": str(self)}


def error_frame(code: str, field: str, expected: str, got: str, message: str = "") -> str:
    """The text frame of a refused request (never a traceback)."""
    message = message or f"{field}: expected {expected}, got {got}"
    return json.dumps({"error": {"code": code, "field": field, "expected": expected, "got": got,
                                 "message": message}, "schema_version": SCHEMA_VERSION})


def describe(value: Any) -> str:
    """What came, for an error message: an array's dtype and shape, else the type and a short repr."""
    if isinstance(value, np.ndarray):
        return f"{value.dtype} array of shape {list(value.shape)}"
    text = repr(value)
    return f"{type(value).__name__} {text[:60]}{'...' if len(text) > 60 else ''}"


def _get(msg: dict, key: str, prefix: str = "") -> Any:
    if key not in msg:
        raise SchemaError(prefix + key, "a value (the field is required)", "nothing")
    return msg[key]


def _string(value: Any, field: str, max_len: int = MAX_TEXT) -> str:
    if not isinstance(value, str) or not value or len(value) > max_len:
        raise SchemaError(field, f"a non-empty string of at most {max_len} characters", describe(value))
    return value


def _integer(value: Any, field: str, low: int = 0) -> int:
    if isinstance(value, np.integer):
        value = int(value)
    if not isinstance(value, int) or isinstance(value, bool) or value < low:
        raise SchemaError(field, f"an integer >= {low}", describe(value))
    return value


def _number(value: Any, field: str, low: float | None = None, high: float | None = None) -> float:
    if isinstance(value, (np.floating, np.integer)):
        value = value.item()
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value) or (
            low is not None and value < low) or (high is not None and value > high):
        bounds = f" in [{low}, {high}]" if low is not None else ""
        raise SchemaError(field, f"a finite number{bounds}", describe(value))
    return float(value)


def _array(value: Any, field: str, shape: tuple[int | None, ...], kinds: str, finite: bool = True) -> np.ndarray:
    """``value`` as an array of ``shape`` (None: any size) with a dtype kind in ``kinds`` ("f" float, "u"/"i"
    integer, "b" bool); float arrays must hold finite values."""
    kind_names = {"f": "float", "u": "unsigned integer", "i": "integer", "b": "bool"}
    want = f"{' or '.join(kind_names[k] for k in kinds)} array of shape {list(d if d else 'N' for d in shape)}"
    if not isinstance(value, np.ndarray) or value.dtype.kind not in kinds or value.ndim != len(shape) or any(
            d is not None and d != n for d, n in zip(shape, value.shape)):
        raise SchemaError(field, want, describe(value))
    if finite and value.dtype.kind == "f" and not np.isfinite(value).all():
        raise SchemaError(field, "finite values", f"{int((~np.isfinite(value)).sum())} NaN or infinite values")
    return value


def _names(value: Any, field: str) -> list[str]:
    if not isinstance(value, list) or len(value) > MAX_NAMES or not all(isinstance(v, str) for v in value):
        raise SchemaError(field, f"a list of at most {MAX_NAMES} strings", describe(value))
    return value


@dataclass
class ParsedObservation:
    observation: KeyframeObservation
    episode_id: str
    has_maps: bool  # the cameras carried instance and class maps


def parse_observation(msg: Any) -> ParsedObservation:
    """A checked observation message as the policy's ``KeyframeObservation``; ``SchemaError`` names the first
    field that is wrong."""
    if not isinstance(msg, dict):
        raise SchemaError("message", "a map", describe(msg), code="bad_message")
    version = _get(msg, "schema_version")
    if type(version) is not int or version != SCHEMA_VERSION:
        raise SchemaError("schema_version", str(SCHEMA_VERSION), describe(version), code="schema_version")
    episode_id = _string(_get(msg, "episode_id"), "episode_id", 256)
    keyframe = _integer(_get(msg, "keyframe"), "keyframe")
    instruction = _string(_get(msg, "instruction"), "instruction")
    nouns = _names(msg["goal_nouns"], "goal_nouns") if "goal_nouns" in msg else extract_goal_nouns(instruction)

    cameras = _get(msg, "cameras")
    if not isinstance(cameras, dict) or not 1 <= len(cameras) <= MAX_CAMERAS:
        raise SchemaError("cameras", f"a map of 1 to {MAX_CAMERAS} cameras by name", describe(cameras))
    rgb, depth, instance, classes, intrinsics, extrinsics = [], [], [], [], [], []
    size: tuple[int, int] | None = None
    maps: bool | None = None
    for name, cam in cameras.items():
        p = f"cameras.{name}."
        if not isinstance(name, str) or not isinstance(cam, dict):
            raise SchemaError(f"cameras.{name}", "a camera map under a string name", describe(cam))
        image = _array(_get(cam, "rgb", p), p + "rgb", (None, None, 3), "u")
        if image.dtype != np.uint8:
            raise SchemaError(p + "rgb", "uint8 values", describe(image))
        h, w = image.shape[:2]
        if not (1 <= h <= MAX_SIDE and 1 <= w <= MAX_SIDE):
            raise SchemaError(p + "rgb", f"sides between 1 and {MAX_SIDE} pixels", describe(image))
        if size is None:
            size = (h, w)
        elif (h, w) != size:
            raise SchemaError(p + "rgb", f"the same size as the first camera ({size[0]}x{size[1]})", f"{h}x{w}")
        d = _array(_get(cam, "depth", p), p + "depth", (h, w), "f")
        if (d < 0).any():
            raise SchemaError(p + "depth", "metres >= 0", f"min {float(d.min()):.3f}")
        k = _array(_get(cam, "intrinsics", p), p + "intrinsics", (3, 3), "f")
        e = _array(_get(cam, "extrinsics", p), p + "extrinsics", (4, 4), "f")
        has = "instance" in cam or "class" in cam
        if maps is not None and has != maps:
            raise SchemaError(p + "instance", "instance and class maps on every camera or on none",
                              "maps on some cameras only")
        maps = has
        if has:
            instance.append(_array(_get(cam, "instance", p), p + "instance", (h, w), "ui", finite=False))
            classes.append(_array(_get(cam, "class", p), p + "class", (h, w), "ui", finite=False))
        rgb.append(image)
        depth.append(d.astype(np.float32))
        intrinsics.append(k)
        extrinsics.append(e)

    instance_names: list[str] = []
    class_names: list[str] = []
    if maps:
        instance_names = _names(_get(msg, "instance_names"), "instance_names")
        class_names = _names(_get(msg, "class_names"), "class_names")
        for field, ids, names in (("instance", instance, instance_names), ("class", classes, class_names)):
            top = max(int(a.max()) for a in ids) if ids else 0
            if top >= max(len(names), 1) or min(int(a.min()) for a in ids) < 0 or top > np.iinfo(np.int16).max:
                raise SchemaError(f"cameras.*.{field}", f"ids in [0, {len(names)}) (one per {field}_names entry)",
                                  f"ids up to {top}")
    colours: dict[str, list[str]] = {}
    if "instance_colours" in msg:
        raw = msg["instance_colours"]
        if not isinstance(raw, dict) or len(raw) > MAX_NAMES or not all(isinstance(k, str) for k in raw):
            raise SchemaError("instance_colours", "a map from instance name to a list of colour names",
                              describe(raw))
        colours = {k: _names(v, f"instance_colours.{k}") for k, v in raw.items()}

    arms = _get(msg, "arms")
    if not isinstance(arms, dict) or not 1 <= len(arms) <= MAX_ARMS:
        raise SchemaError("arms", f"a map of 1 to {MAX_ARMS} arms by name", describe(arms))
    proprio, bases = [], {}
    for name, arm in arms.items():
        p = f"arms.{name}."
        if not isinstance(name, str) or not isinstance(arm, dict):
            raise SchemaError(f"arms.{name}", "an arm map under a string name", describe(arm))
        pose = _array(_get(arm, "pose", p), p + "pose", (7,), "f")
        quat_norm = float(np.linalg.norm(pose[3:]))
        if not 0.9 < quat_norm < 1.1:
            raise SchemaError(p + "pose", "a unit quaternion (x, y, z, w) in entries 3-6", f"norm {quat_norm:.3f}")
        grip = _number(_get(arm, "gripper_open", p), p + "gripper_open", 0.0, 1.0)
        base = _array(_get(arm, "base", p), p + "base", (3,), "f")
        proprio.append(np.r_[pose, grip].astype(np.float32))  # as sent: a reply must not depend on the wire
        bases[name] = [float(v) for v in base]

    n_cam = len(rgb)
    h, w = size  # type: ignore[misc]
    scene = SceneInfo(list(cameras), list(arms), instance_names, class_names, list(nouns), bases, colours)
    obs = KeyframeObservation(
        np.stack(rgb), np.stack(depth),
        np.stack(instance).astype(np.int16) if maps else np.zeros((n_cam, h, w), np.int16),
        np.stack(classes).astype(np.int16) if maps else np.zeros((n_cam, h, w), np.int16),
        np.stack(intrinsics), np.stack(extrinsics), np.stack(proprio), instruction, keyframe, scene)
    return ParsedObservation(obs, episode_id, bool(maps))


def observation_message(obs: KeyframeObservation, episode_id: str, with_maps: bool = True) -> dict[str, Any]:
    """The message a robot sends for ``obs`` (the simulated robot sends its segmentation maps too)."""
    cameras: dict[str, Any] = {}
    for i, name in enumerate(obs.scene.camera_names):
        cam = {"rgb": obs.rgb[i], "depth": obs.depth[i].astype(np.float32), "intrinsics": obs.intrinsics[i],
               "extrinsics": obs.extrinsics[i]}
        if with_maps:
            cam["instance"], cam["class"] = obs.instance[i], obs.class_ids[i]
        cameras[name] = cam
    msg: dict[str, Any] = {
        "schema_version": SCHEMA_VERSION, "episode_id": episode_id, "keyframe": int(obs.keyframe_index),
        "instruction": obs.instruction, "cameras": cameras,
        "arms": {arm: {"pose": np.asarray(obs.proprio[a, :7], np.float32), "gripper_open": float(obs.proprio[a, 7]),
                       "base": np.asarray(obs.scene.arm_bases[arm], np.float64)}
                 for a, arm in enumerate(obs.scene.arm_names)}}
    if obs.scene.goal_nouns:  # else the server parses them from the instruction
        msg["goal_nouns"] = list(obs.scene.goal_nouns)
    if with_maps:
        msg["instance_names"], msg["class_names"] = list(obs.scene.instance_names), list(obs.scene.class_names)
        if obs.scene.instance_colours:
            msg["instance_colours"] = {k: list(v) for k, v in obs.scene.instance_colours.items()}
    return msg


def reply_message(episode_id: str, keyframe: int, arm_names: list[str], action: np.ndarray,
                  timing: dict[str, float], diagnostics: dict[str, Any]) -> dict[str, Any]:
    action = np.asarray(action, np.float32)
    return {"schema_version": SCHEMA_VERSION, "episode_id": episode_id, "keyframe": keyframe,
            "actions": {arm: {"pose": action[a, :7], "gripper_open": float(action[a, 7]),
                              "ignore_collisions": float(action[a, 8])} for a, arm in enumerate(arm_names)},
            "action": action, "timing": timing, "diagnostics": diagnostics}


def action_from_reply(reply: Any, arm_names: list[str]) -> np.ndarray:
    """The (arms, 9) world rows of a reply, in ``arm_names`` order; ``SchemaError`` if it is not a valid reply."""
    if not isinstance(reply, dict) or reply.get("schema_version") != SCHEMA_VERSION:
        raise SchemaError("reply", f"a schema-{SCHEMA_VERSION} reply map", describe(reply), code="bad_reply")
    actions = _get(reply, "actions")
    rows = []
    for arm in arm_names:
        if not isinstance(actions, dict) or arm not in actions:
            raise SchemaError(f"actions.{arm}", "an action for every arm", describe(actions), code="bad_reply")
        a = actions[arm]
        pose = _array(_get(a, "pose", f"actions.{arm}."), f"actions.{arm}.pose", (7,), "f")
        rows.append(np.r_[pose, _number(a.get("gripper_open"), f"actions.{arm}.gripper_open", 0.0, 1.0),
                          _number(a.get("ignore_collisions"), f"actions.{arm}.ignore_collisions", 0.0, 1.0)])
    return np.asarray(rows, np.float32)


def chunk_from_reply(reply: dict, arm_count: int) -> np.ndarray | None:
    """The reply's (arms, k, 9) world rows where the policy planned k keyframes ahead (the first is ``action``),
    or None where it sent no chunk; ``SchemaError`` if the chunk is malformed."""
    if reply.get("chunk") is None:
        return None
    chunk = _array(reply["chunk"], "chunk", (arm_count, None, 9), "f")
    if chunk.shape[1] < 1:
        raise SchemaError("chunk", "at least one planned keyframe", describe(chunk), code="bad_reply")
    return chunk.astype(np.float32)
