"""Typed options from the command line with ``tyro``: a dataclass's fields become ``--field-name`` flags, their
comments the help. Two rules keep the flags every earlier command line used: booleans read ``true``/``false``
(any case, or 1/0, yes/no; a bare ``--flag`` is true), and a plain ``dict`` field reads one JSON object
(``--model '{"dim": 64}'``)."""

from __future__ import annotations

import json
from typing import Any, TypeVar

import tyro
from tyro.constructors import ConstructorRegistry, PrimitiveConstructorSpec, PrimitiveTypeInfo

T = TypeVar("T")
TRUE, FALSE = ("true", "1", "yes"), ("false", "0", "no")

_REGISTRY = ConstructorRegistry()


def _read_bool(args: list[str]) -> bool:
    if not args:  # a bare --flag
        return True
    word = args[0].lower()
    if word not in TRUE + FALSE:
        raise ValueError(f"expected true or false, got {args[0]!r}")
    return word in TRUE


def _read_json_object(args: list[str]) -> dict:
    try:
        value = json.loads(args[0])
    except json.JSONDecodeError as err:
        raise ValueError(f"expected a JSON object such as '{{\"dim\": 64}}', got {args[0]!r} ({err.msg})") from err
    if not isinstance(value, dict):
        raise ValueError(f"expected a JSON object such as '{{\"dim\": 64}}', got {args[0]!r}")
    return value


@_REGISTRY.primitive_rule
def _bool_rule(info: PrimitiveTypeInfo) -> PrimitiveConstructorSpec | None:
    if info.type is not bool:
        return None
    return PrimitiveConstructorSpec(nargs=(0, 1), metavar="[{true,false}]", instance_from_str=_read_bool,
                                    is_instance=lambda x: isinstance(x, bool),
                                    str_from_instance=lambda x: [str(x).lower()])


@_REGISTRY.primitive_rule
def _dict_rule(info: PrimitiveTypeInfo) -> PrimitiveConstructorSpec | None:
    if info.type is not dict:
        return None
    return PrimitiveConstructorSpec(nargs=1, metavar="JSON", instance_from_str=_read_json_object,
                                    is_instance=lambda x: isinstance(x, dict),
                                    str_from_instance=lambda x: [json.dumps(x)])


def parse(cls: type[T], args: list[str], prog: str, description: str, default: T | None = None) -> T:
    """``cls`` from ``args`` (``default``'s values where a flag is not given); ``--help`` prints and exits 0, a
    malformed flag prints tyro's message and exits 2."""
    config: tuple[Any, ...] = (tyro.conf.FlagConversionOff, tyro.conf.OmitArgPrefixes)
    with _REGISTRY:
        return tyro.cli(cls, args=args, prog=prog, description=description, default=default, config=config)
