"""Protocol v1 codec: encode messages to ``[topic, body]`` frames, decode and validate them."""

from __future__ import annotations

import math
from dataclasses import fields, replace

import msgpack
import numpy as np

from streamseg.exceptions import ProtocolError
from streamseg.protocol.messages import (
    _DTYPES,
    MESSAGES,
    PROTOCOL_VERSION,
    Announce,
    Closed,
    Confirm,
    Cut,
    End,
    Error,
    Frames,
    Gap,
    Hello,
    Rep,
    Segments,
    Stats,
    WireError,
    Withdraw,
    topic,
    valid_stream_id,
)
from streamseg.recording import UP_AXES


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


# left out when None (older readers)
_OPTIONAL = {
    "announce": ("labels", "labels_sequence", "auth"),
    "end": ("auth",),
    "cut": ("pending", "revision"),
    "confirm": ("settled", "revision"),
    "withdraw": ("revision",),
    "gap": ("filled",),
}


def encode(msg, seq: int | None = None) -> list[bytes]:
    """The two frames ``[topic, body]`` of a message object.

    ``seq`` (the daemon's per-stream event sequence number) overrides ``msg.seq``; an event
    without one is sent without the field.
    """
    body = {"v": PROTOCOL_VERSION, "type": msg.type}
    optional = _OPTIONAL.get(msg.type, ())
    for f in fields(msg):
        value = getattr(msg, f.name)
        if value is None and f.name in optional:
            continue
        if isinstance(value, np.ndarray):
            value = encode_array(value)
        elif f.name == "seq" and value is None and msg.type != "frames":
            continue
        body[f.name] = value
    if seq is not None:
        body["seq"] = seq
    # a hello is routed by its token, so only the subscriber that asked receives it
    stream = msg.token if msg.type == "hello" else getattr(msg, "stream", None)
    return [topic(msg.type, stream), msgpack.packb(body, use_bin_type=True)]


def unpack_body(body: bytes) -> dict:
    """Unpack and check the envelope (``v``, ``type``) of a body; raises WireError."""
    try:
        obj = msgpack.unpackb(body, raw=False, strict_map_key=False)
    except Exception as err:  # msgpack raises several unrelated classes on garbage
        raise WireError(
            "decode", f"body is not valid msgpack ({type(err).__name__}: {err})"
        ) from err
    if not isinstance(obj, dict):
        raise WireError("decode", f"body must be a msgpack map, got {type(obj).__name__}")
    stream = obj.get("stream")
    stream = stream if isinstance(stream, str) else None
    v = obj.get("v")
    if v != PROTOCOL_VERSION:
        raise WireError(
            "version",
            f"protocol version {v!r} is not supported: this daemon "
            f"speaks v{PROTOCOL_VERSION} (docs/protocol.md); upgrade the sender",
            stream,
        )
    kind = obj.get("type")
    if type(kind) is not str or kind not in MESSAGES:
        raise WireError(
            "type",
            f"unknown message type {_short(kind)}; expected one of {', '.join(MESSAGES)}",
            stream,
        )
    return obj


def decode(frames) -> object:
    """Validate ``[topic, body]`` frames and return the message object; raises WireError."""
    if len(frames) != 2:
        raise WireError("decode", f"expected 2 message parts [topic, body], got {len(frames)}")
    obj = unpack_body(bytes(frames[1]))
    return from_body(obj)


def from_body(obj: dict):
    """Build the message object from an unpacked body (see :func:`unpack_body`)."""
    kind = obj["type"]
    stream = obj.get("stream") if isinstance(obj.get("stream"), str) else None
    try:
        msg = _BUILDERS[kind](obj)
        if kind in _NUMBERED and obj.get("seq") is not None:
            msg = replace(msg, seq=_int(obj, "seq", kind, stream, minimum=1))
        return msg
    except KeyError as err:
        raise WireError(
            "field", f"{kind} message lacks field {err.args[0]!r} (see docs/protocol.md)", stream
        ) from err
    except (TypeError, ValueError) as err:
        if isinstance(err, WireError):
            raise
        raise WireError(
            "field", f"{kind} message has a field of the wrong type: {err}", stream
        ) from err


def _need(cond: bool, kind: str, what: str, value, expected: str, stream=None) -> None:
    if not cond:
        raise WireError(
            "field", f"{kind}.{what}={_short(value)} is invalid: expected {expected}", stream
        )


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _stream(obj, kind) -> str:
    s = obj["stream"]
    _need(valid_stream_id(s), kind, "stream", s, "1-128 characters of A-Za-z0-9_.:@+=-")
    return s


MAX_INT = 2**53  # frame numbers and counts stay exact as floats and fit msgpack's int64


def _int(obj, key, kind, stream, minimum=0) -> int:
    v = obj[key]
    _need(
        type(v) is int and minimum <= v < MAX_INT,
        kind,
        key,
        v,
        f"an integer in [{minimum}, 2**53)",
        stream,
    )
    return v


def _num(obj, key, kind, stream, finite=True) -> float:
    v = obj[key]
    _need(
        type(v) in (int, float) and (not finite or math.isfinite(v)),
        kind,
        key,
        v,
        "a finite number" if finite else "a number",
        stream,
    )
    return float(v)


def _rep_label(obj):
    """A ``rep`` event's optional action label: int or nil (absent: nil)."""
    v = obj.get("label")
    _need(
        v is None or (type(v) is int and 0 <= v < MAX_INT),
        "rep",
        "label",
        v,
        "nil or an integer in [0, 2**53)",
        None,
    )
    return v


def _rep_measures(obj):
    """A ``rep`` event's optional ``duration_s``, ``rom_deg``, ``rom_joint``, ``likeness``
    (nil or absent: None)."""
    out = []
    for key in ("duration_s", "rom_deg"):
        out.append(None if obj.get(key) is None else _num(obj, key, "rep", None))
    joint = obj.get("rom_joint")
    _need(
        joint is None or (isinstance(joint, str) and 0 < len(joint) <= 64),
        "rep",
        "rom_joint",
        joint,
        "nil or a joint name",
        None,
    )
    like = obj.get("likeness")
    _need(
        like is None or (type(like) in (int, float) and 0 <= like <= 1),
        "rep",
        "likeness",
        like,
        "nil or a number in [0, 1]",
        None,
    )
    return (*out, joint, None if like is None else float(like))


def _announce(obj):
    s = _stream(obj, "announce")
    fps = _num(obj, "fps", "announce", s)
    _need(fps > 0, "announce", "fps", fps, "a frame rate > 0", s)
    joints, parents = obj["joints"], obj["parents"]
    _need(
        isinstance(joints, list)
        and 0 < len(joints) <= 1024
        and all(isinstance(j, str) for j in joints),
        "announce",
        "joints",
        joints,
        "a list of 1-1024 joint names",
        s,
    )
    _need(
        isinstance(parents, list)
        and len(parents) == len(joints)
        and all(type(p) is int and -1 <= p < len(joints) for p in parents),
        "announce",
        "parents",
        parents,
        f"{len(joints)} parent indices in [-1, n_joints)",
        s,
    )
    units = obj.get("units", "mm")
    _need(
        isinstance(units, str) and len(units) <= 64,
        "announce",
        "units",
        units,
        "a string of at most 64 characters (e.g. mm, cm, inch*0.45)",
        s,
    )
    up = obj.get("up", "y")
    _need(up in UP_AXES, "announce", "up", up, f"one of {', '.join(UP_AXES)}", s)
    labels, seq = obj.get("labels"), obj.get("labels_sequence")
    for key, value in (("labels", labels), ("labels_sequence", seq)):
        _need(
            value is None or (isinstance(value, str) and 0 < len(value) <= 4096),
            "announce",
            key,
            value,
            "a string of 1-4096 characters, or nil",
            s,
        )
    auth = obj.get("auth")
    return Announce(
        s,
        fps,
        tuple(joints),
        tuple(parents),
        units,
        up,
        labels,
        seq,
        auth if isinstance(auth, str) else None,
    )


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


def _frames(obj):
    s = _stream(obj, "frames")
    return Frames(s, *frames_fields(obj, s))


def _segments(obj):
    s = _stream(obj, "segments")
    segs = obj["segments"]
    _need(
        isinstance(segs, list)
        and all(
            isinstance(x, list) and len(x) == 3 and all(type(i) is int for i in x) for x in segs
        ),
        "segments",
        "segments",
        segs,
        "a list of [start, end, label] integer triples",
        s,
    )
    return Segments(
        s,
        _int(obj, "revision", "segments", s),
        _int(obj, "start", "segments", s),
        _int(obj, "end", "segments", s),
        tuple(tuple(x) for x in segs),
        bool(obj.get("final", False)),
        float(obj.get("elapsed", 0.0)),
    )


def _error(obj):
    s = obj.get("stream")
    _need(s is None or isinstance(s, str), "error", "stream", s, "a string or nil")
    reason, message = obj["reason"], obj["message"]
    _need(
        isinstance(reason, str) and isinstance(message, str),
        "error",
        "reason",
        reason,
        "strings reason and message",
        s,
    )
    return Error(s, reason, message, _int(obj, "count", "error", s))


def _pending(obj):
    """A cut's optional ``pending`` flag: True, or None when absent (final when emitted)."""
    value = obj.get("pending")
    _need(
        value is None or isinstance(value, bool),
        "cut",
        "pending",
        value,
        "a bool",
        _stream(obj, "cut"),
    )
    return True if value else None


def _maybe_int(obj, key: str, kind: str):
    """An optional integer field: the int, or None when absent (older daemons)."""
    if obj.get(key) is None:
        return None
    return _int(obj, key, kind, obj.get("stream") if isinstance(obj.get("stream"), str) else None)


def _flag(obj, key: str, kind: str):
    """An optional bool field: True/False, or None when absent."""
    value = obj.get(key)
    _need(
        value is None or isinstance(value, bool),
        kind,
        key,
        value,
        "a bool",
        obj.get("stream") if isinstance(obj.get("stream"), str) else None,
    )
    return value


def _stats(obj):
    totals, streams, last = obj["totals"], obj["streams"], obj.get("last_seq", {})
    _need(
        isinstance(totals, dict) and isinstance(streams, dict),
        "stats",
        "totals",
        totals,
        "maps totals and streams",
    )
    _need(
        isinstance(last, dict) and all(type(n) is int for n in last.values()),
        "stats",
        "last_seq",
        last,
        "a map of stream ids to event numbers",
    )
    return Stats(_num(obj, "uptime", "stats", None), totals, streams, last)


_BUILDERS = {
    "announce": _announce,
    "frames": _frames,
    "end": lambda o: End(_stream(o, "end"), o["auth"] if isinstance(o.get("auth"), str) else None),
    "cut": lambda o: Cut(
        _stream(o, "cut"),
        _int(o, "frame", "cut", None),
        _num(o, "time", "cut", None, finite=False),
        _num(o, "score", "cut", None, finite=False),
        _int(o, "emitted_at", "cut", None),
        bool(o["provisional"]),
        _pending(o),
        _maybe_int(o, "revision", "cut"),
    ),
    "confirm": lambda o: Confirm(
        _stream(o, "confirm"),
        _int(o, "frame", "confirm", None),
        _num(o, "time", "confirm", None, finite=False),
        _num(o, "score", "confirm", None, finite=False),
        _int(o, "emitted_at", "confirm", None),
        _maybe_int(o, "settled", "confirm"),
        _maybe_int(o, "revision", "confirm"),
    ),
    "withdraw": lambda o: Withdraw(
        _stream(o, "withdraw"),
        _int(o, "frame", "withdraw", None),
        _num(o, "time", "withdraw", None, finite=False),
        _int(o, "emitted_at", "withdraw", None),
        bool(o.get("moved", False)),
        _maybe_int(o, "revision", "withdraw"),
    ),
    "segments": _segments,
    "rep": lambda o: Rep(
        _stream(o, "rep"),
        _int(o, "start", "rep", None),
        _int(o, "end", "rep", None),
        _int(o, "count", "rep", None),
        _num(o, "time", "rep", None, finite=False),
        _int(o, "emitted_at", "rep", None),
        _rep_label(o),
        _int(o, "set_index", "rep", None) if "set_index" in o else 0,
        *_rep_measures(o),
    ),
    "gap": lambda o: Gap(
        _stream(o, "gap"),
        _int(o, "expected", "gap", None),
        _int(o, "got", "gap", None),
        _flag(o, "filled", "gap"),
    ),
    "error": _error,
    "stats": _stats,
    "hello": lambda o: Hello(str(o["token"])),
    "closed": lambda o: Closed(
        _stream(o, "closed"), str(o["reason"]), _int(o, "frames", "closed", None)
    ),
}


_NUMBERED = frozenset({"cut", "confirm", "withdraw", "segments", "rep", "gap", "error", "closed"})


# left out when None, as on the wire
_JSON_OPTIONAL = {
    "cut": ("pending", "revision"),
    "confirm": ("settled", "revision"),
    "withdraw": ("revision",),
    "gap": ("filled",),
}


def to_json(msg) -> dict:
    """A JSON-able dict of an event: its fields plus ``type`` (arrays become nested lists)."""
    out = {"type": msg.type}
    for f in fields(msg):
        value = getattr(msg, f.name)
        if isinstance(value, np.ndarray):
            value = value.tolist()
        elif f.name == "seq" and value is None and msg.type != "frames":
            continue
        elif value is None and f.name in _JSON_OPTIONAL.get(msg.type, ()):
            continue
        elif isinstance(value, tuple):
            value = [list(x) if isinstance(x, tuple) else x for x in value]
        out[f.name] = value
    return out
