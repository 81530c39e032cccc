"""What crosses the pipe between the judge (the grader's process) and the sandboxed child that calls the student's
functions: plain data only, one JSON object per line, nothing that unpickles.

A value is JSON (numbers, strings, booleans, null, lists, objects with string keys); NaN and infinities are written
as JSON's usual extensions (NaN, Infinity). A numpy array of more than SMALL numbers travels as
{"ndarray": base64 of its bytes (C order, little-endian), "dtype": one of DTYPES, "shape": [...]}; a smaller one
as nested lists. Decoding checks the dtype against DTYPES and the byte count against the shape, and builds the
array with numpy.frombuffer (never pickle). This module is copied into the sandbox with the child (no grader state
in it)."""

from __future__ import annotations

import base64
import json
import math
import os
import select
import time

import numpy as np

__all__ = ["DTYPES", "SMALL", "MAX_LINE", "WireError", "encode", "decode", "dumps", "loads", "LineReader"]

DTYPES = ("bool", "uint8", "int8", "uint16", "int16", "int32", "int64", "uint32", "float32", "float64")
SMALL = 256                  # arrays of at most this many numbers go as nested lists
MAX_LINE = 128 * 2**20       # bytes of one message at most (a 1280 x 720 float64 image is 10 MB in base64)
_MAX_DEPTH = 64


class WireError(ValueError):
    """A message that is not plain data of the protocol (malformed, too deep, too large, an unknown dtype)."""


def encode(value, depth: int = 0):
    """`value` as plain JSON-able data: numpy arrays (binary form above SMALL numbers), numpy scalars, tuples and
    lists, dicts with string keys, str, bool, int, float, None. TypeError for anything else (an object of the
    kit's: the adapter turns it into numbers first)."""
    if depth > _MAX_DEPTH:
        raise TypeError("value nested too deep to send")
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, (int, float)):
        return value
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        if value.dtype.name not in DTYPES:
            value = value.astype(float)
        if value.size <= SMALL:
            return value.tolist()
        data = np.ascontiguousarray(value, dtype=value.dtype.newbyteorder("<"))
        return {"ndarray": base64.b64encode(data.tobytes()).decode("ascii"), "dtype": value.dtype.name,
                "shape": list(value.shape)}
    if isinstance(value, (list, tuple)):
        return [encode(v, depth + 1) for v in value]
    if isinstance(value, dict) and all(isinstance(k, str) for k in value):
        return {k: encode(v, depth + 1) for k, v in value.items()}
    raise TypeError(f"cannot send a {type(value).__name__} as plain data")


def decode(value, depth: int = 0):
    """The Python value of plain data: binary arrays become numpy arrays, everything else stays as JSON gave it."""
    if depth > _MAX_DEPTH:
        raise WireError("nested too deep")
    if isinstance(value, list):
        return [decode(v, depth + 1) for v in value]
    if isinstance(value, dict):
        if set(value) == {"ndarray", "dtype", "shape"}:
            return _array(value)
        return {k: decode(v, depth + 1) for k, v in value.items()}
    return value


def _array(spec: dict) -> np.ndarray:
    dtype, shape, data = spec["dtype"], spec["shape"], spec["ndarray"]
    if dtype not in DTYPES or not isinstance(data, str) or not isinstance(shape, list) or len(shape) > 8 or \
            not all(isinstance(n, int) and not isinstance(n, bool) and 0 <= n for n in shape):
        raise WireError(f"not an array of the protocol: dtype {dtype!r}, shape {shape!r}")
    raw = base64.b64decode(data.encode("ascii"), validate=True)
    want = np.dtype(dtype).newbyteorder("<")
    if len(raw) != math.prod(shape) * want.itemsize:
        raise WireError(f"array of shape {shape} and dtype {dtype} holds {len(raw)} bytes")
    return np.frombuffer(raw, dtype=want).astype(dtype).reshape(shape)


def dumps(message: dict) -> bytes:
    """One line of the protocol."""
    return json.dumps(message, allow_nan=True, separators=(",", ":")).encode() + b"\n"


def loads(line: bytes) -> dict:
    """The message of one line: a JSON object (WireError otherwise)."""
    try:
        message = json.loads(line)
    except (ValueError, RecursionError) as e:
        raise WireError(f"not a JSON line ({type(e).__name__})") from None
    if not isinstance(message, dict):
        raise WireError("a message is a JSON object")
    return message


class LineReader:
    """Lines from a pipe's file descriptor, each at most MAX_LINE bytes, with a deadline (time.monotonic())."""

    def __init__(self, fd: int):
        self.fd, self._buffer = fd, b""

    def line(self, deadline: float | None = None) -> bytes:
        """The next line; TimeoutError at the deadline, EOFError when the pipe closes first, WireError for a line
        over MAX_LINE."""
        while b"\n" not in self._buffer:
            if len(self._buffer) > MAX_LINE:
                raise WireError(f"a message over {MAX_LINE // 2**20} MB")
            if deadline is not None:
                left = deadline - time.monotonic()
                if left <= 0 or not select.select([self.fd], [], [], left)[0]:
                    raise TimeoutError("no answer in time")
            chunk = os.read(self.fd, 1 << 20)
            if not chunk:
                raise EOFError("the other side closed the pipe")
            self._buffer += chunk
        line, _, self._buffer = self._buffer.partition(b"\n")
        return line
