"""Arrays on the wire (``{"dtype", "shape", "data"}``) and the daemon's fast path through a
``frames`` body, which checks the positions without building a message object."""

from __future__ import annotations

import numpy as np

from streamseg.exceptions import ProtocolError
from streamseg.protocol.fields import MAX_INT, _need, _short
from streamseg.protocol.messages import _DTYPES, WireError


def encode_array(a: np.ndarray) -> dict:
    """``{"dtype", "shape", "data"}`` of a float32/float64 array (little-endian, C order)."""
    a = np.asarray(a)
    if a.dtype.kind != "f" or a.dtype.itemsize not in (4, 8):
        raise ProtocolError(f"array dtype {a.dtype} cannot be sent: expected float32 or float64")
    a = np.ascontiguousarray(a, dtype=a.dtype.newbyteorder("<"))
    return {"dtype": a.dtype.str, "shape": list(a.shape), "data": a.tobytes()}


def decode_array(obj, what: str = "array") -> np.ndarray:
    """Inverse of :func:`encode_array`; a read-only view on the message bytes."""
    try:
        dtype = _DTYPES[obj["dtype"]]
        shape = tuple(obj["shape"])
        data = obj["data"]
    except (KeyError, TypeError) as err:
        raise WireError(
            "array",
            f"{what} must be a map with dtype ('<f4' or '<f8'), shape and "
            f"data (bytes); got {_short(obj)}",
        ) from err
    if not isinstance(data, bytes) or not all(type(s) is int and s >= 0 for s in shape):
        raise WireError("array", f"{what}: shape must be non-negative ints and data bytes")
    n = 1
    for s in shape:
        n *= s
    if len(data) != n * dtype.itemsize:
        raise WireError(
            "array",
            f"{what}: {len(data)} data bytes do not match shape "
            f"{list(shape)} of {dtype.str} ({n * dtype.itemsize} bytes expected)",
        )
    return np.frombuffer(data, dtype=dtype).reshape(shape)


def frames_fields(obj: dict, stream: str | None = None) -> tuple:
    """``(seq, timestamp, positions)`` of an unpacked frames body: the daemon's fast path.

    Validates like :func:`decode` (except the stream id, which the caller looks up) without
    building a :class:`Frames`; ``positions`` is a read-only view on the message bytes.
    """
    try:
        seq, ts, arr = obj["seq"], obj["timestamp"], obj["positions"]
    except KeyError as err:
        raise WireError(
            "field", f"frames message lacks field {err.args[0]!r} (see docs/protocol.md)", stream
        ) from err
    if type(seq) is not int or not 0 <= seq < MAX_INT:
        _need(False, "frames", "seq", seq, "an integer in [0, 2**53)", stream)
    if type(ts) is not float and type(ts) is not int:
        _need(False, "frames", "timestamp", ts, "a number", stream)
    try:
        dtype = _DTYPES[arr["dtype"]]
        shape, data = arr["shape"], arr["data"]
    except (KeyError, TypeError) as err:
        raise WireError(
            "array",
            f"frames.positions must be a map with dtype ('<f4' or '<f8'), "
            f"shape and data (bytes); got {_short(arr)}",
            stream,
        ) from err
    if (
        type(shape) is not list
        or len(shape) != 3
        or type(shape[0]) is not int
        or type(shape[1]) is not int
        or shape[0] < 1
        or shape[1] < 1
        or shape[2] != 3
    ):
        raise WireError(
            "array",
            f"frames.positions has shape {_short(shape)}: expected "
            f"(n_frames >= 1, n_joints >= 1, 3)",
            stream,
        )
    if type(data) is not bytes or len(data) != shape[0] * shape[1] * 3 * dtype.itemsize:
        raise WireError(
            "array",
            f"frames.positions: {len(data)} data bytes do not match "
            f"shape {shape} of {dtype.str} ({shape[0] * shape[1] * 3 * dtype.itemsize}"
            " bytes expected)"
            if type(data) is bytes
            else "frames.positions.data must be bytes",
            stream,
        )
    return seq, float(ts), np.frombuffer(data, dtype=dtype).reshape(shape[0], shape[1], 3)
