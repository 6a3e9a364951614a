"""A corpus of malformed requests for checking a policy server: each case is a valid observation broken in one
way, by class. ``benchmarks/server_fuzz.py`` sends the whole corpus to `bimanualshift serve`; the tests send a
few cases of each class.

Classes: wrong dtypes, wrong shapes, NaN/inf values, truncated frames, garbage (random bytes, msgpack of the
wrong structure, text frames), a wrong schema version, a missing field, oversized frames, bad UTF-8, and a
wrong token (refused at the handshake). Then what is well-formed but beyond the checkpoint: a keyframe past its
episode bound, views that cannot see the workspace, arms it does not have; and a token file that other users can
read (``serve`` must refuse to start).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import msgpack
import numpy as np

from bimanualshift.deploy.codec import CodecError, pack, unpack
from bimanualshift.deploy.schema import SchemaError, parse_observation

CLASSES = ("wrong_dtype", "wrong_shape", "nan_inf", "truncated", "garbage", "schema_version", "missing_field",
           "oversized", "bad_utf8", "wrong_token", "keyframe_bound", "blind_views", "foreign_arms", "token_file_mode")
# the classes a server can only refuse by knowing its checkpoint (``ServedPolicy.check``)
CHECKPOINT_CLASSES = ("keyframe_bound", "blind_views", "foreign_arms")


@dataclass
class Case:
    kind: str  # one of CLASSES
    description: str
    frame: bytes | str | None = None  # what is sent on an open connection (None: a wrong_token case)
    token: str | None = None  # wrong_token: the key this connection attempt sends (None: no header)
    mode: int | None = None  # token_file_mode: the permission bits of the token file ``serve`` is started with


def _array_fields(msg: dict[str, Any]) -> list[tuple[tuple[str, ...], np.ndarray]]:
    """Every array in the message with its path of keys."""
    out = []

    def walk(node: Any, path: tuple[str, ...]) -> None:
        if isinstance(node, dict):
            for key, value in node.items():
                walk(value, (*path, key))
        elif isinstance(node, np.ndarray):
            out.append((path, node))

    walk(msg, ())
    return out


def _set(msg: dict[str, Any], path: tuple[str, ...], value: Any) -> dict[str, Any]:
    msg = copy.deepcopy(msg)
    node = msg
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return msg


def _delete(msg: dict[str, Any], path: tuple[str, ...]) -> dict[str, Any]:
    msg = copy.deepcopy(msg)
    node = msg
    for key in path[:-1]:
        node = node[key]
    del node[path[-1]]
    return msg


def _required_paths(msg: dict[str, Any]) -> list[tuple[str, ...]]:
    paths: list[tuple[str, ...]] = [("schema_version",), ("episode_id",), ("keyframe",), ("instruction",),
                                    ("cameras",), ("arms",)]
    for cam, fields in msg["cameras"].items():
        paths += [("cameras", cam, f) for f in fields]
    for arm, fields in msg["arms"].items():
        paths += [("arms", arm, f) for f in fields]
    if "instance_names" in msg:
        paths += [("instance_names",), ("class_names",)]
    return paths


# A dtype each field must not carry (the schema wants uint8 images, float geometry and integer maps).
def _wrong_dtypes(path: tuple[str, ...]) -> list[str]:
    if path[-1] == "rgb":
        return ["float32", "uint16", "int64", "bool", "float64"]
    if path[-1] in ("instance", "class"):
        return ["float32", "float64", "bool"]
    return ["int32", "uint8", "bool", "int64"]


def _wrong_dtype(rng: np.random.Generator, msg: dict[str, Any]) -> Case:
    path, array = _array_fields(msg)[rng.integers(len(_array_fields(msg)))]
    if rng.random() < 0.2:  # a dtype the codec itself refuses, forged past numpy's own packer
        dtype = ["<c8", "|O", "|V4", "<M8[D]", ">f4", "<U1"][rng.integers(6)]
        forged = {b"__ndarray__": True, b"data": b"\0" * 4, b"dtype": dtype, b"shape": [1]}
        frame = msgpack.packb(_set(msg, path, _Forged(forged)), default=_encode_any, use_bin_type=True)
        return Case("wrong_dtype", f"{'.'.join(path)} forged as dtype {dtype}", frame)
    dtype = _wrong_dtypes(path)[rng.integers(len(_wrong_dtypes(path)))]
    return Case("wrong_dtype", f"{'.'.join(path)} as {dtype}", pack(_set(msg, path, array.astype(dtype))))


@dataclass
class _Forged:
    """A raw array map sent as it is (numpy would refuse to build it)."""

    raw: dict[bytes, Any]


def _encode_any(obj: Any) -> Any:
    if isinstance(obj, _Forged):
        return obj.raw
    if isinstance(obj, np.ndarray):
        return {b"__ndarray__": True, b"data": obj.tobytes(), b"dtype": obj.dtype.str, b"shape": list(obj.shape)}
    raise TypeError(type(obj))


def _wrong_shape(rng: np.random.Generator, msg: dict[str, Any]) -> Case:
    fields = _array_fields(msg)
    path, array = fields[rng.integers(len(fields))]
    choice = rng.integers(4)
    if choice == 0 and array.ndim > 1:
        bad = array.reshape(-1)
    elif choice == 1:
        bad = array[..., None]
    elif choice == 2:
        bad = np.concatenate([array, array[..., :1]], axis=-1)
    else:
        bad = array[..., :-1] if array.shape[-1] > 1 else np.zeros((0,), array.dtype)
    return Case("wrong_shape", f"{'.'.join(path)} with shape {list(bad.shape)} (was {list(array.shape)})",
                pack(_set(msg, path, bad)))


def _nan_inf(rng: np.random.Generator, msg: dict[str, Any]) -> Case:
    floats = [(p, a) for p, a in _array_fields(msg) if a.dtype.kind == "f"]
    bad_value = [np.nan, np.inf, -np.inf][rng.integers(3)]
    if rng.random() < 0.15:
        arm = list(msg["arms"])[0]
        return Case("nan_inf", f"arms.{arm}.gripper_open = {bad_value}",
                    pack(_set(msg, ("arms", arm, "gripper_open"), float(bad_value))))
    path, array = floats[rng.integers(len(floats))]
    bad = array.copy()
    bad.reshape(-1)[rng.integers(bad.size)] = bad_value
    return Case("nan_inf", f"{'.'.join(path)} holds {bad_value}", pack(_set(msg, path, bad)))


def _truncated(rng: np.random.Generator, msg: dict[str, Any]) -> Case:
    frame = pack(msg)
    cut = int(rng.integers(1, len(frame)))
    return Case("truncated", f"the frame cut at byte {cut} of {len(frame)}", frame[:cut])


def _garbage(rng: np.random.Generator, msg: dict[str, Any]) -> Case:
    choice = rng.integers(5)
    if choice == 0:
        n = int(rng.integers(1, 4096))
        return Case("garbage", f"{n} random bytes", rng.bytes(n))
    if choice == 1:
        value = [[1, 2, 3], 42, "observation", None, 3.5, True, b"\x00\x01"][rng.integers(7)]
        return Case("garbage", f"msgpack of a {type(value).__name__}", msgpack.packb(value))
    if choice == 2:
        return Case("garbage", "a text frame", "{\"instruction\": \"push the button\"}")
    if choice == 3:
        depth = int(rng.integers(200, 100_000))  # one-element arrays inside each other, then a 0
        return Case("garbage", f"lists nested {depth} deep", b"\x91" * depth + b"\x00")
    while True:  # bytes landing in pixel data can leave a valid observation: keep only frames the schema refuses
        noisy = bytearray(pack(msg))
        for i in rng.integers(0, len(noisy), size=int(rng.integers(1, 64))):
            noisy[i] = int(rng.integers(256))
        if not _valid(bytes(noisy)):
            return Case("garbage", "a valid frame with random bytes overwritten", bytes(noisy))


def _valid(frame: bytes) -> bool:
    """Whether ``frame`` decodes to an observation the schema accepts (then an action is the right answer)."""
    try:
        parse_observation(unpack(frame))
    except (CodecError, SchemaError):
        return False
    return True


def _schema_version(rng: np.random.Generator, msg: dict[str, Any]) -> Case:
    value = [0, 2, -1, 999, "1", 1.0, None, True, [1], {"v": 1}][rng.integers(10)]
    return Case("schema_version", f"schema_version = {value!r}", pack(_set(msg, ("schema_version",), value)))


def _missing_field(rng: np.random.Generator, msg: dict[str, Any]) -> Case:
    paths = _required_paths(msg)
    path = paths[rng.integers(len(paths))]
    return Case("missing_field", f"no {'.'.join(path)}", pack(_delete(msg, path)))


def _oversized(rng: np.random.Generator, msg: dict[str, Any], limit: int) -> Case:
    extra = int(rng.integers(1, limit))  # up to twice the limit: the server reads it and refuses it
    return Case("oversized", f"padded to the limit + {extra} bytes",
                pack({**msg, "padding": np.zeros(limit + extra, np.uint8)}))


def _bad_utf8(rng: np.random.Generator, msg: dict[str, Any]) -> Case:
    where = ["instruction", "episode_id", "camera name", "arm name"][rng.integers(4)]
    marker = "Z" * 24
    if where == "instruction":
        broken = _set(msg, ("instruction",), marker)
    elif where == "episode_id":
        broken = _set(msg, ("episode_id",), marker)
    elif where == "camera name":
        broken = copy.deepcopy(msg)
        first = list(broken["cameras"])[0]
        broken["cameras"] = {marker if k == first else k: v for k, v in broken["cameras"].items()}
    else:
        broken = copy.deepcopy(msg)
        first = list(broken["arms"])[0]
        broken["arms"] = {marker if k == first else k: v for k, v in broken["arms"].items()}
    invalid = [b"\xff", b"\xc3\x28", b"\xe2\x82", b"\xed\xa0\x80", b"\xf8\x88\x80\x80\x80"][rng.integers(5)]
    bad = (invalid * 24)[:24]
    return Case("bad_utf8", f"{where} with bytes {invalid!r}", pack(broken).replace(marker.encode(), bad, 1))


def _wrong_token(rng: np.random.Generator, msg: dict[str, Any], token: str) -> Case:
    choice = rng.integers(5)
    bad = [None, "", token[:-1], token + "x", "".join(reversed(token))][choice]
    return Case("wrong_token", f"API key {['absent', 'empty', 'truncated', 'extended', 'reversed'][choice]}",
                None, bad)


def _keyframe_bound(rng: np.random.Generator, msg: dict[str, Any], max_keyframe: int) -> Case:
    choice = rng.integers(4)
    value = [max_keyframe + 1, 2**63 - 1, 2**64 - 1, int(rng.integers(max_keyframe + 2, 2**62))][choice]
    return Case("keyframe_bound", f"keyframe = {value} (the bound is {max_keyframe})",
                pack(_set(msg, ("keyframe",), value)))


def _look(extrinsics: np.ndarray, how: str, rng: np.random.Generator) -> np.ndarray:
    e = np.array(extrinsics, np.float64)
    if how == "away":  # turned half a turn about its own x axis: the table is behind it
        e[:3, :3] = e[:3, :3] @ np.diag([1.0, -1.0, -1.0])
    elif how == "far":  # tens of metres off
        e[:3, 3] += rng.uniform(20, 200) * rng.choice([-1, 1], 3)
    elif how == "singular":  # no rotation at all
        e[:3, :3] = 0.0
    return e


def _blind_views(rng: np.random.Generator, msg: dict[str, Any]) -> Case:
    how = ["away", "far", "singular", "zoomed", "one wrist"][rng.integers(5)]
    broken = copy.deepcopy(msg)
    names = list(broken["cameras"])
    if how == "one wrist":  # a single camera, pointed away: alone it sees none of the table
        keep = names[rng.integers(len(names))]
        cam = broken["cameras"][keep]
        cam["extrinsics"] = _look(cam["extrinsics"], "away", rng)
        broken["cameras"] = {f"cam_{rng.integers(1000)}": cam}
        return Case("blind_views", f"only {keep}, renamed and turned away", pack(broken))
    for name in names:
        cam = broken["cameras"][name]
        if how == "zoomed":  # a focal length a thousand times too long: a pinhole's view of a few millimetres
            k = np.array(cam["intrinsics"], np.float64)
            k[0, 0] *= 1000.0
            k[1, 1] *= 1000.0
            cam["intrinsics"] = k
        else:
            cam["extrinsics"] = _look(cam["extrinsics"], how, rng)
    return Case("blind_views", f"every camera {how}", pack(broken))


def _foreign_arms(rng: np.random.Generator, msg: dict[str, Any]) -> Case:
    broken = copy.deepcopy(msg)
    names = list(broken["arms"])
    choice = rng.integers(4)
    extra = ["middle", "third", "left2", "arm_2", "head"][rng.integers(5)]
    if choice == 0:  # a third arm beside the two
        broken["arms"][extra] = copy.deepcopy(broken["arms"][names[0]])
        what = f"a third arm, arms.{extra}"
    elif choice == 1:  # an arm under a name the checkpoint does not know
        broken["arms"] = {extra if k == names[-1] else k: v for k, v in broken["arms"].items()}
        what = f"arms.{names[-1]} renamed {extra}"
    elif choice == 2:  # both arms, in the other order: each would get the other's arm index
        broken["arms"] = dict(reversed(list(broken["arms"].items())))
        what = "the arms in reverse order"
    else:  # as many arms as the schema allows
        for i in range(4 - len(names)):
            broken["arms"][f"{extra}_{i}"] = copy.deepcopy(broken["arms"][names[0]])
        what = "four arms"
    return Case("foreign_arms", what, pack(broken))


def _token_file_mode(rng: np.random.Generator) -> Case:
    while True:  # owner read, and at least one bit for group or others
        mode = 0o400 | int(rng.integers(0, 0o1000))
        if mode & 0o077:
            return Case("token_file_mode", f"token file mode {mode:04o}", mode=mode)


def corpus(valid: dict[str, Any], per_class: int, limit: int, token: str, seed: int = 0,
           max_keyframe: int = 49, classes: tuple[str, ...] = CLASSES) -> Iterator[Case]:
    """``per_class`` cases of each of ``classes``, interleaved, from a valid observation message ``valid``;
    ``limit`` is the server's frame limit (oversized cases exceed it by up to 2x), ``token`` its real token and
    ``max_keyframe`` its checkpoint's last keyframe index (its metadata's ``max_keyframe``)."""
    rng = np.random.default_rng(seed)
    makers: dict[str, Callable[[], Case]] = {
        "wrong_dtype": lambda: _wrong_dtype(rng, valid), "wrong_shape": lambda: _wrong_shape(rng, valid),
        "nan_inf": lambda: _nan_inf(rng, valid), "truncated": lambda: _truncated(rng, valid),
        "garbage": lambda: _garbage(rng, valid), "schema_version": lambda: _schema_version(rng, valid),
        "missing_field": lambda: _missing_field(rng, valid), "oversized": lambda: _oversized(rng, valid, limit),
        "bad_utf8": lambda: _bad_utf8(rng, valid), "wrong_token": lambda: _wrong_token(rng, valid, token),
        "keyframe_bound": lambda: _keyframe_bound(rng, valid, max_keyframe),
        "blind_views": lambda: _blind_views(rng, valid), "foreign_arms": lambda: _foreign_arms(rng, valid),
        "token_file_mode": lambda: _token_file_mode(rng)}
    for _ in range(per_class):
        for kind in classes:
            yield makers[kind]()
