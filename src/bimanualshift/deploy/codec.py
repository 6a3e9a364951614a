"""msgpack frames with numpy arrays, wire-compatible with openpi's ``msgpack_numpy`` (the ``openpi-client``
package), but refusing what a network peer should never be able to send.

An array travels as a map ``{b"__ndarray__": True, b"data": bytes, b"dtype": str, b"shape": [..]}`` and a numpy
scalar as ``{b"__npgeneric__": True, b"data": value, b"dtype": str}``, as openpi's client packs them. Decoding
accepts only the dtypes in ``ALLOWED_DTYPES`` (little-endian or byte-order-free numbers and bools), checks that
the bytes match the shape, and copies the data into a fresh array; nothing is ever unpickled or evaluated.
"""

from __future__ import annotations

import math
from typing import Any

import msgpack
import numpy as np

# dtype.str of every dtype a frame may carry; the rest (object, void/structured, complex, strings, datetimes,
# big-endian) is refused on both sides.
ALLOWED_DTYPES: frozenset[str] = frozenset(np.dtype(t).newbyteorder("<").str for t in (
    np.bool_, np.uint8, np.int8, np.uint16, np.int16, np.uint32, np.int32, np.uint64, np.int64,
    np.float16, np.float32, np.float64))
MAX_NDIM = 8


class CodecError(ValueError):
    """A frame that cannot be decoded (or a value that cannot be encoded); the message says what was wrong."""


def _check_dtype(dtype: np.dtype) -> None:
    if dtype.str not in ALLOWED_DTYPES:
        raise CodecError(f"dtype {dtype.str!r} is not allowed on the wire; allowed: {sorted(ALLOWED_DTYPES)}")


def _encode(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        _check_dtype(obj.dtype)
        return {b"__ndarray__": True, b"data": np.ascontiguousarray(obj).tobytes(), b"dtype": obj.dtype.str,
                b"shape": list(obj.shape)}
    if isinstance(obj, np.generic):
        _check_dtype(obj.dtype)
        return {b"__npgeneric__": True, b"data": obj.item(), b"dtype": obj.dtype.str}
    raise CodecError(f"cannot encode a {type(obj).__name__}: send numbers, strings, bytes, lists, maps or numpy "
                     "arrays")


def pack(obj: Any) -> bytes:
    """One frame's bytes."""
    try:
        return msgpack.packb(obj, default=_encode, use_bin_type=True)
    except CodecError:
        raise
    except (TypeError, ValueError, OverflowError) as err:
        raise CodecError(f"cannot encode the message: {err}") from None


def _decode_array(obj: dict) -> np.ndarray:
    dtype_name, shape, data = obj.get(b"dtype"), obj.get(b"shape"), obj.get(b"data")
    if not isinstance(dtype_name, str) or dtype_name not in ALLOWED_DTYPES:
        raise CodecError(f"array dtype {dtype_name!r} is not allowed; allowed: {sorted(ALLOWED_DTYPES)}")
    if not isinstance(shape, (list, tuple)) or len(shape) > MAX_NDIM or not all(
            isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in shape):
        raise CodecError(f"array shape must be a list of at most {MAX_NDIM} non-negative integers, got {shape!r}")
    if not isinstance(data, bytes):
        raise CodecError(f"array data must be bytes, got {type(data).__name__}")
    dtype = np.dtype(dtype_name)
    expected = math.prod(shape) * dtype.itemsize
    if len(data) != expected:
        raise CodecError(f"array of shape {list(shape)} and dtype {dtype_name} needs {expected} bytes, got {len(data)}")
    return np.frombuffer(data, dtype=dtype).reshape(shape).copy()


def _decode_scalar(obj: dict) -> np.generic:
    dtype_name, value = obj.get(b"dtype"), obj.get(b"data")
    if not isinstance(dtype_name, str) or dtype_name not in ALLOWED_DTYPES:
        raise CodecError(f"scalar dtype {dtype_name!r} is not allowed; allowed: {sorted(ALLOWED_DTYPES)}")
    if not isinstance(value, (bool, int, float)):
        raise CodecError(f"scalar data must be a number, got {type(value).__name__}")
    dtype = np.dtype(dtype_name)
    if dtype.kind in "iu" and (isinstance(value, float) or not np.iinfo(dtype).min <= value <= np.iinfo(dtype).max):
        raise CodecError(f"scalar {value!r} does not fit dtype {dtype_name}")
    return dtype.type(value)


def _object_hook(obj: dict) -> Any:
    if b"__ndarray__" in obj:
        return _decode_array(obj)
    if b"__npgeneric__" in obj:
        return _decode_scalar(obj)
    return obj


def _refuse_ext(code: int, data: bytes) -> Any:
    raise CodecError(f"msgpack extension type {code} is not accepted")


def unpack(frame: bytes, max_bytes: int | None = None) -> Any:
    """A frame's value; ``CodecError`` for anything malformed (truncated or trailing bytes, bad UTF-8, unknown
    extension types, disallowed dtypes, arrays whose bytes do not match their shape) or above ``max_bytes``."""
    if not isinstance(frame, (bytes, bytearray, memoryview)):
        raise CodecError(f"a frame must be bytes, got {type(frame).__name__}")
    if max_bytes is not None and len(frame) > max_bytes:
        raise CodecError(f"frame of {len(frame)} bytes exceeds the limit of {max_bytes}")
    try:
        return msgpack.unpackb(frame, object_hook=_object_hook, ext_hook=_refuse_ext, raw=False,
                               strict_map_key=False)
    except CodecError:
        raise
    except UnicodeDecodeError as err:
        raise CodecError(f"a string in the frame is not valid UTF-8 ({err.reason} at byte {err.start})") from None
    except (msgpack.ExtraData, msgpack.FormatError, msgpack.StackError, ValueError, TypeError) as err:
        raise CodecError(f"not a valid msgpack frame: {type(err).__name__}: {err}") from None
