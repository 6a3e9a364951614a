"""Reading the ``config.json`` and ``model.safetensors`` of a checkpoint with errors that name the file, the
field, what was expected and how to fix it (instead of a library's bare message from deep inside)."""

from __future__ import annotations

import dataclasses
import json
import types
import typing
from pathlib import Path
from typing import Any


class CheckpointError(ValueError):
    """A checkpoint file that exists but cannot be used as it is."""


def read_json_file(path: str | Path, what: str = "config") -> dict[str, Any]:
    path = Path(path)
    if not path.is_file():
        where = "that folder does not exist" if not path.parent.is_dir() else f"{path.name} is missing there"
        raise FileNotFoundError(f"no {what} at {path.parent} ({where}); check the path")
    try:
        raw = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise CheckpointError(f"{path} is not valid JSON ({err.msg} at line {err.lineno}, column {err.colno}); "
                              f"fix the file or re-save the {what}") from err
    if not isinstance(raw, dict):
        raise CheckpointError(f"{path} holds a {type(raw).__name__}, expected a JSON object of {what} fields")
    return raw


def _accepts(annotation: Any, value: Any) -> bool:
    """Whether a JSON value fits a dataclass field's annotation (ints count as floats; lists as tuples)."""
    origin = typing.get_origin(annotation)
    if annotation is Any:
        return True
    if origin in (typing.Union, types.UnionType):
        return any(_accepts(a, value) for a in typing.get_args(annotation))
    if annotation is type(None):
        return value is None
    if origin in (tuple, list):
        return isinstance(value, list | tuple)
    if origin is dict:
        return isinstance(value, dict)
    if annotation is bool:
        return isinstance(value, bool)
    if annotation is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if annotation is float:
        return isinstance(value, int | float) and not isinstance(value, bool)
    if isinstance(annotation, type):
        return isinstance(value, annotation)
    return True


def _nested(cls: type) -> dict[str, type]:
    """The fields of dataclass ``cls`` that are dataclasses themselves (a nested config's groups)."""
    hints = typing.get_type_hints(cls)
    return {f.name: hints[f.name] for f in dataclasses.fields(cls) if dataclasses.is_dataclass(hints[f.name])}


def _group_default(cls: type, name: str) -> Any:
    """The default value of ``cls``'s nested group ``name`` (its default_factory's, or the group class's own)."""
    spec = next(f for f in dataclasses.fields(cls) if f.name == name)
    if spec.default_factory is not dataclasses.MISSING:
        return spec.default_factory()
    if spec.default is not dataclasses.MISSING:
        return spec.default
    return typing.get_type_hints(cls)[name]()


def route_flat_keys(cls: type, raw: dict[str, Any]) -> dict[str, Any]:
    """``raw`` with every key that names a field of exactly one nested group moved into that group: a flat
    config (an older run's, or keyword arguments) read as the nested one."""
    groups = _nested(cls)
    own = {f.name for f in dataclasses.fields(cls)}
    out: dict[str, Any] = {}
    moved: dict[str, dict[str, Any]] = {g: {} for g in groups}
    for key, value in raw.items():
        if key in own and not (key in groups and not isinstance(value, dict)):
            out[key] = dict(value) if key in groups else value
            continue
        owners = [g for g, sub in groups.items() if key in {f.name for f in dataclasses.fields(sub)}]
        if len(owners) == 1:
            moved[owners[0]][key] = value
        else:
            out[key] = value  # unknown: the caller names it
    for group, values in moved.items():
        if values:
            out[group] = {**(out.get(group) or {}), **values}
    return out


def config_from_dict(cls: type, raw: dict[str, Any], source: str | Path, ignore_unknown: bool = True) -> Any:
    """An instance of dataclass ``cls`` from ``raw``, every value checked against its field's type; lists become
    tuples where the field holds a tuple. Nested groups are read from their own objects, or from flat keys (an
    older, flat config). ``source`` (the file) is named in every error."""
    hints = typing.get_type_hints(cls)
    groups = _nested(cls)
    raw = route_flat_keys(cls, raw) if groups else raw
    names = {f.name for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(raw) - names)
    if unknown and not ignore_unknown:
        raise CheckpointError(f"{source}: unknown keys {unknown}; {cls.__name__} has {sorted(names)}")
    values = {}
    for key in names & set(raw):
        value = raw[key]
        if key in groups and isinstance(value, dict):
            given = config_from_dict(groups[key], value, f"{source} ({key})", ignore_unknown)
            # the group's unnamed fields keep the parent's default for it (e.g. the residual's own optimiser
            # settings), not the group class's generic ones
            values[key] = dataclasses.replace(_group_default(cls, key), **{
                f.name: getattr(given, f.name) for f in dataclasses.fields(given) if f.name in value})
            continue
        if not _accepts(hints[key], value):
            expected = getattr(hints[key], "__name__", str(hints[key]))
            raise CheckpointError(f"{source}: field {key!r} is {value!r} ({type(value).__name__}), expected "
                                  f"{expected}; correct it in that file (or re-save the checkpoint)")
        values[key] = tuple(value) if isinstance(value, list) and typing.get_origin(hints[key]) is tuple else value
    return cls(**values)


def config_from_flat(cls: type, **values: Any) -> Any:
    """A (nested) config from flat keyword arguments, each routed to its group and checked:
    ``config_from_flat(TrainConfig, task="lift_ball", steps=2)``."""
    return config_from_dict(cls, values, f"{cls.__name__} arguments", ignore_unknown=False)


def load_safetensors(path: str | Path) -> dict[str, Any]:
    """The tensors of ``path``; a truncated or corrupt file is named with the fix."""
    from safetensors import SafetensorError
    from safetensors.torch import load_file

    try:
        return load_file(str(path))
    except SafetensorError as err:
        size = Path(path).stat().st_size
        raise CheckpointError(f"{path} ({size:,} bytes) is not a readable safetensors file ({err}): it is probably "
                              "truncated or corrupt; copy it again, or re-save the checkpoint") from err


def load_checked_weights(model: Any, weights: str | Path, fix: str) -> None:
    """Load ``weights`` into ``model`` (a torch module) after checking every tensor's name and shape; a mismatch
    names the file, the tensors and ``fix``."""
    state = load_safetensors(weights)
    expected = model.state_dict()
    shapes = [f"{k}: checkpoint {tuple(state[k].shape)} vs model {tuple(v.shape)}"
              for k, v in expected.items() if k in state and state[k].shape != v.shape]
    missing = [k for k in expected if k not in state]
    unexpected = [k for k in state if k not in expected]
    if shapes or missing or unexpected:
        raise CheckpointError(f"{weights} does not match its config.json: shape mismatches {shapes[:5]}, missing "
                              f"{missing[:5]}, unexpected {unexpected[:5]}; {fix}")
    model.load_state_dict(state)
