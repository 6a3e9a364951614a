"""The wire codec: every allowed dtype round-trips exactly, everything else is refused, and openpi's own codec
reads what it writes and vice versa."""

from __future__ import annotations

import msgpack
import numpy as np
import pytest
from openpi_client import msgpack_numpy

from bimanualshift.deploy.codec import ALLOWED_DTYPES, CodecError, pack, unpack


@pytest.mark.parametrize("dtype", sorted(ALLOWED_DTYPES))
def test_every_allowed_dtype_round_trips_exactly(dtype: str) -> None:
    rng = np.random.default_rng(0)
    array = (rng.random((3, 4, 2)) * 100).astype(np.dtype(dtype))
    back = unpack(pack({"a": array, "s": array.reshape(-1)[0]}))
    assert back["a"].dtype == array.dtype and back["a"].shape == array.shape
    assert back["a"].tobytes() == array.tobytes()
    assert back["a"].flags.writeable  # a copy, not a view into the frame
    assert back["s"] == array.reshape(-1)[0]
    if dtype != "<f8":  # a float64 scalar is a Python float: msgpack packs it as one, as openpi's codec does
        assert back["s"].dtype == array.dtype


@pytest.mark.parametrize("value", [np.array([1 + 2j]), np.array(["a"]), np.array([b"x"]), np.array([object()]),
                                   np.zeros(2, dtype=[("x", "f4")]), np.array(["2020-01-01"], "datetime64[D]"),
                                   np.zeros(2, ">f4")])
def test_other_dtypes_are_refused_on_both_sides(value: np.ndarray) -> None:
    with pytest.raises(CodecError, match="not allowed"):
        pack({"a": value})
    forged = msgpack.packb({"a": {b"__ndarray__": True, b"data": value.tobytes() if value.dtype != object else b"",
                                  b"dtype": value.dtype.str, b"shape": list(value.shape)}})
    with pytest.raises(CodecError, match="not allowed"):
        unpack(forged)


def test_openpi_codec_interoperates() -> None:
    obs = {"rgb": np.arange(12, dtype=np.uint8).reshape(2, 2, 3), "depth": np.ones((2, 2), np.float32), "k": 3}
    theirs = unpack(msgpack_numpy.packb(obs))
    assert theirs["rgb"].tobytes() == obs["rgb"].tobytes() and theirs["k"] == 3
    ours = msgpack_numpy.unpackb(pack(obs))
    assert np.array_equal(ours["depth"], obs["depth"]) and ours["depth"].dtype == np.float32


@pytest.mark.parametrize("frame, message", [
    (pack({"a": np.zeros(4, np.float32)})[:-3], "not a valid msgpack frame"),  # truncated
    (pack({"a": 1}) + b"\x01", "not a valid msgpack frame"),  # trailing bytes
    (b"\xa2\xff\xfe", "not valid UTF-8"),  # a str with bad UTF-8
    (msgpack.packb(msgpack.ExtType(5, b"x")), "extension type"),
    (msgpack.packb({b"__ndarray__": True, b"data": b"\0" * 7, b"dtype": "<f4", b"shape": [2]}), "needs 8 bytes"),
    (msgpack.packb({b"__ndarray__": True, b"data": b"", b"dtype": "<f4", b"shape": [-1]}), "non-negative"),
    (msgpack.packb({b"__ndarray__": True, b"data": b"", b"dtype": "O", b"shape": [0]}), "not allowed"),
    (msgpack.packb({b"__npgeneric__": True, b"data": 300, b"dtype": "|u1"}), "does not fit"),
])
def test_malformed_frames_raise_codec_errors(frame: bytes, message: str) -> None:
    with pytest.raises(CodecError, match=message):
        unpack(frame)


def test_size_limit() -> None:
    frame = pack({"a": np.zeros(1000, np.uint8)})
    assert unpack(frame, max_bytes=len(frame))["a"].shape == (1000,)
    with pytest.raises(CodecError, match="exceeds the limit"):
        unpack(frame, max_bytes=len(frame) - 1)
