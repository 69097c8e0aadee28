"""The streamseg wire protocol, version 1 (specified field by field in ``docs/protocol.md``).

Every message is a ZeroMQ multipart message of exactly two frames ``[topic, body]``:

- ``topic`` is ASCII ``<type>/<stream>/`` (``<type>/*/`` for daemon-wide messages). Type comes
  first so that one SUB prefix selects one event type across all streams (``cut/``); one
  stream's events of every type are ``len(EVENT_TYPES)`` subscriptions (``cut/s1/``,
  ``segments/s1/``, ...). The trailing ``/`` stops ``cut/s1/`` from matching stream ``s10``.
- ``body`` is a msgpack map holding ``v`` (the protocol version), ``type`` and the fields of
  the message. The body is authoritative; the topic is only for routing.

Arrays travel as a map ``{"dtype": "<f4" | "<f8", "shape": [n, J, 3], "data": <bytes>}``
(little-endian, C order), never pickle.

:func:`encode` turns a message object into the two frames; :func:`decode` validates and turns
them back, raising :class:`WireError` (a :class:`~streamseg.exceptions.ProtocolError` with a
``kind`` for counting) with a message that says what was wrong and what was expected.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, fields

import msgpack
import numpy as np

from streamseg.exceptions import ProtocolError

PROTOCOL_VERSION = 1
INGEST_TYPES = ("announce", "frames", "end")
EVENT_TYPES = ("cut", "segments", "rep", "gap", "error", "stats", "closed")
DAEMON_WIDE = "*"
_STREAM_RE = re.compile(r"[A-Za-z0-9_.:@+=-]{1,128}\Z")
_DTYPES = {"<f4": np.dtype("<f4"), "<f8": np.dtype("<f8")}


class WireError(ProtocolError):
    """A message failed decoding or validation.

    Attributes
    ----------
    kind : str
        Short machine-readable class of the problem (``decode``, ``field``, ``array``,
        ``version``, ``type``); the daemon counts errors per kind and stream.
    stream : str or None
        The stream the message named, when that much could be read.
    """

    def __init__(self, kind: str, message: str, stream: str | None = None):
        super().__init__(message)
        self.kind = kind
        self.stream = stream


def valid_stream_id(stream) -> bool:
    """True when ``stream`` may be used as a stream id (1-128 of ``A-Za-z0-9_.:@+=-``)."""
    return isinstance(stream, str) and _STREAM_RE.match(stream) is not None


def topic(kind: str, stream: str | None) -> bytes:
    """The topic frame of a message of type ``kind`` about ``stream`` (None: daemon-wide)."""
    return f"{kind}/{stream if stream is not None else DAEMON_WIDE}/".encode("ascii")


def subscriptions(stream: str | None = None, kind: str | None = None) -> list[bytes]:
    """SUB prefixes selecting events of ``stream`` and/or type ``kind`` (None: any)."""
    kinds = [kind] if kind else list(EVENT_TYPES)
    if stream is None:
        return [f"{k}/".encode("ascii") for k in kinds] if kind else [b""]
    return [topic(k, stream) for k in kinds]


# --- messages ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Announce:
    """Ingest: a stream starts. ``parents[j]`` is the index of joint j's parent, -1 for roots."""

    stream: str
    fps: float
    joints: tuple[str, ...]
    parents: tuple[int, ...]
    units: str = "mm"

    type = "announce"


@dataclass(frozen=True, eq=False)
class Frames:
    """Ingest: ``positions`` (n, n_joints, 3) float32/float64 starting at frame ``seq``.

    ``seq`` is the 0-based stream frame index of the first frame (so a gap or a duplicate is
    visible in frames, not packets); ``timestamp`` is the sender's clock (s) at that frame.
    """

    stream: str
    seq: int
    timestamp: float
    positions: np.ndarray

    type = "frames"

    def __eq__(self, other):
        if not isinstance(other, Frames):
            return NotImplemented
        return (self.stream == other.stream and self.seq == other.seq
                and _same_float(self.timestamp, other.timestamp)
                and self.positions.dtype == other.positions.dtype
                and self.positions.shape == other.positions.shape
                and np.array_equal(self.positions, other.positions, equal_nan=True))

    __hash__ = None


@dataclass(frozen=True)
class End:
    """Ingest: the stream is over; the daemon publishes final events and a ``closed`` event."""

    stream: str

    type = "end"


@dataclass(frozen=True)
class Cut:
    """Event: a provisional cut (a new segment starts at ``frame``), found at ``emitted_at``."""

    stream: str
    frame: int
    time: float
    score: float
    emitted_at: int
    provisional: bool = True

    type = "cut"


@dataclass(frozen=True)
class Segments:
    """Event: relabelled segmentation of frames ``[start, end)`` of a stream.

    ``segments`` holds ``(start, end, label)`` triples (end exclusive) with labels kept stable
    across revisions; it supersedes every provisional cut inside ``[start, end)``.
    ``revision`` increases by one per relabel of the stream; ``final`` marks the last one.
    """

    stream: str
    revision: int
    start: int
    end: int
    segments: tuple[tuple[int, int, int], ...]
    final: bool = False
    elapsed: float = 0.0

    type = "segments"


@dataclass(frozen=True)
class Rep:
    """Event: a repetition in frames ``[start, end)``, the ``count``-th of the current set,
    found when frame ``emitted_at`` arrived."""

    stream: str
    start: int
    end: int
    count: int
    time: float
    emitted_at: int = 0

    type = "rep"


@dataclass(frozen=True)
class Gap:
    """Event: frames ``[expected, got)`` of a stream never arrived (``got - expected`` lost)."""

    stream: str
    expected: int
    got: int

    type = "gap"


@dataclass(frozen=True)
class Error:
    """Event: bad input. ``count`` is how many times ``reason`` happened for ``stream``."""

    stream: str | None
    reason: str
    message: str
    count: int = 1

    type = "error"


@dataclass(frozen=True)
class Stats:
    """Event: heartbeat. ``totals`` daemon-wide counters; ``streams`` per-stream counters."""

    uptime: float
    totals: dict = field(default_factory=dict)
    streams: dict = field(default_factory=dict)

    type = "stats"


@dataclass(frozen=True)
class Closed:
    """Event: a stream's state was dropped (``reason``: end, idle, shutdown) after ``frames``."""

    stream: str
    reason: str
    frames: int

    type = "closed"


MESSAGES = {cls.type: cls for cls in (Announce, Frames, End, Cut, Segments, Rep, Gap, Error,
                                      Stats, Closed)}


def _same_float(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


# --- encoding ------------------------------------------------------------------------------


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
        raise WireError("array", f"{what} must be a map with dtype ('<f4' or '<f8'), shape and "
                        f"data (bytes); got {_short(obj)}") from err
    if not isinstance(data, bytes) or not all(type(s) is int and s >= 0 for s in shape):
        raise WireError("array", f"{what}: shape must be non-negative ints and data bytes")
    n = 1
    for s in shape:
        n *= s
    if len(data) != n * dtype.itemsize:
        raise WireError("array", f"{what}: {len(data)} data bytes do not match shape "
                        f"{list(shape)} of {dtype.str} ({n * dtype.itemsize} bytes expected)")
    return np.frombuffer(data, dtype=dtype).reshape(shape)


def encode(msg) -> list[bytes]:
    """The two frames ``[topic, body]`` of a message object."""
    body = {"v": PROTOCOL_VERSION, "type": msg.type}
    for f in fields(msg):
        value = getattr(msg, f.name)
        if isinstance(value, np.ndarray):
            value = encode_array(value)
        body[f.name] = value
    stream = getattr(msg, "stream", None)
    return [topic(msg.type, stream), msgpack.packb(body, use_bin_type=True)]


def unpack_body(body: bytes) -> dict:
    """Unpack and check the envelope (``v``, ``type``) of a body; raises WireError."""
    try:
        obj = msgpack.unpackb(body, raw=False, strict_map_key=False)
    except Exception as err:  # msgpack raises several unrelated classes on garbage
        raise WireError("decode", f"body is not valid msgpack ({type(err).__name__}: {err})") \
            from err
    if not isinstance(obj, dict):
        raise WireError("decode", f"body must be a msgpack map, got {type(obj).__name__}")
    stream = obj.get("stream")
    stream = stream if isinstance(stream, str) else None
    v = obj.get("v")
    if v != PROTOCOL_VERSION:
        raise WireError("version", f"protocol version {v!r} is not supported: this daemon "
                        f"speaks v{PROTOCOL_VERSION} (docs/protocol.md); upgrade the sender",
                        stream)
    kind = obj.get("type")
    if type(kind) is not str or kind not in MESSAGES:
        raise WireError("type", f"unknown message type {_short(kind)}; expected one of "
                        f"{', '.join(MESSAGES)}", stream)
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
        return _BUILDERS[kind](obj)
    except KeyError as err:
        raise WireError("field", f"{kind} message lacks field {err.args[0]!r} "
                        f"(see docs/protocol.md)", stream) from err
    except (TypeError, ValueError) as err:
        if isinstance(err, WireError):
            raise
        raise WireError("field", f"{kind} message has a field of the wrong type: {err}",
                        stream) from err


def _need(cond: bool, kind: str, what: str, value, expected: str, stream=None) -> None:
    if not cond:
        raise WireError("field", f"{kind}.{what}={_short(value)} is invalid: expected {expected}",
                        stream)


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
    _need(type(v) is int and minimum <= v < MAX_INT, kind, key, v,
          f"an integer in [{minimum}, 2**53)", stream)
    return v


def _num(obj, key, kind, stream, finite=True) -> float:
    v = obj[key]
    _need(type(v) in (int, float) and (not finite or math.isfinite(v)), kind, key, v,
          "a finite number" if finite else "a number", stream)
    return float(v)


def _announce(obj):
    s = _stream(obj, "announce")
    fps = _num(obj, "fps", "announce", s)
    _need(fps > 0, "announce", "fps", fps, "a frame rate > 0", s)
    joints, parents = obj["joints"], obj["parents"]
    _need(isinstance(joints, list) and 0 < len(joints) <= 1024
          and all(isinstance(j, str) for j in joints), "announce", "joints", joints,
          "a list of 1-1024 joint names", s)
    _need(isinstance(parents, list) and len(parents) == len(joints)
          and all(type(p) is int and -1 <= p < len(joints) for p in parents),
          "announce", "parents", parents, f"{len(joints)} parent indices in [-1, n_joints)", s)
    units = obj.get("units", "mm")
    _need(isinstance(units, str) and len(units) <= 64, "announce", "units", units,
          "a string of at most 64 characters (e.g. mm, cm, inch*0.45)", s)
    return Announce(s, fps, tuple(joints), tuple(parents), units)


def frames_fields(obj: dict, stream: str | None = None) -> tuple:
    """``(seq, timestamp, positions)`` of an unpacked frames body: the daemon's fast path.

    Validates like :func:`decode` (except the stream id, which the caller looks up) without
    building a :class:`Frames`; ``positions`` is a read-only view on the message bytes.
    """
    try:
        seq, ts, arr = obj["seq"], obj["timestamp"], obj["positions"]
    except KeyError as err:
        raise WireError("field", f"frames message lacks field {err.args[0]!r} "
                        f"(see docs/protocol.md)", stream) from err
    if type(seq) is not int or not 0 <= seq < MAX_INT:
        _need(False, "frames", "seq", seq, "an integer in [0, 2**53)", stream)
    if type(ts) is not float and type(ts) is not int:
        _need(False, "frames", "timestamp", ts, "a number", stream)
    try:
        dtype = _DTYPES[arr["dtype"]]
        shape, data = arr["shape"], arr["data"]
    except (KeyError, TypeError) as err:
        raise WireError("array", f"frames.positions must be a map with dtype ('<f4' or '<f8'), "
                        f"shape and data (bytes); got {_short(arr)}", stream) from err
    if (type(shape) is not list or len(shape) != 3 or type(shape[0]) is not int
            or type(shape[1]) is not int or shape[0] < 1 or shape[1] < 1 or shape[2] != 3):
        raise WireError("array", f"frames.positions has shape {_short(shape)}: expected "
                        f"(n_frames >= 1, n_joints >= 1, 3)", stream)
    if type(data) is not bytes or len(data) != shape[0] * shape[1] * 3 * dtype.itemsize:
        raise WireError("array", f"frames.positions: {len(data)} data bytes do not match "
                        f"shape {shape} of {dtype.str} ({shape[0] * shape[1] * 3 * dtype.itemsize}"
                        " bytes expected)" if type(data) is bytes else
                        "frames.positions.data must be bytes", stream)
    return seq, float(ts), np.frombuffer(data, dtype=dtype).reshape(shape[0], shape[1], 3)


def _frames(obj):
    s = _stream(obj, "frames")
    return Frames(s, *frames_fields(obj, s))


def _segments(obj):
    s = _stream(obj, "segments")
    segs = obj["segments"]
    _need(isinstance(segs, list) and all(isinstance(x, list) and len(x) == 3
                                         and all(type(i) is int for i in x) for x in segs),
          "segments", "segments", segs, "a list of [start, end, label] integer triples", s)
    return Segments(s, _int(obj, "revision", "segments", s), _int(obj, "start", "segments", s),
                    _int(obj, "end", "segments", s), tuple(tuple(x) for x in segs),
                    bool(obj.get("final", False)), float(obj.get("elapsed", 0.0)))


def _error(obj):
    s = obj.get("stream")
    _need(s is None or isinstance(s, str), "error", "stream", s, "a string or nil")
    reason, message = obj["reason"], obj["message"]
    _need(isinstance(reason, str) and isinstance(message, str), "error", "reason", reason,
          "strings reason and message", s)
    return Error(s, reason, message, _int(obj, "count", "error", s))


def _stats(obj):
    totals, streams = obj["totals"], obj["streams"]
    _need(isinstance(totals, dict) and isinstance(streams, dict), "stats", "totals", totals,
          "maps totals and streams")
    return Stats(_num(obj, "uptime", "stats", None), totals, streams)


_BUILDERS = {
    "announce": _announce,
    "frames": _frames,
    "end": lambda o: End(_stream(o, "end")),
    "cut": lambda o: Cut(_stream(o, "cut"), _int(o, "frame", "cut", None),
                         _num(o, "time", "cut", None, finite=False),
                         _num(o, "score", "cut", None, finite=False),
                         _int(o, "emitted_at", "cut", None), bool(o["provisional"])),
    "segments": _segments,
    "rep": lambda o: Rep(_stream(o, "rep"), _int(o, "start", "rep", None),
                         _int(o, "end", "rep", None), _int(o, "count", "rep", None),
                         _num(o, "time", "rep", None, finite=False),
                         _int(o, "emitted_at", "rep", None)),
    "gap": lambda o: Gap(_stream(o, "gap"), _int(o, "expected", "gap", None),
                         _int(o, "got", "gap", None)),
    "error": _error,
    "stats": _stats,
    "closed": lambda o: Closed(_stream(o, "closed"), str(o["reason"]),
                               _int(o, "frames", "closed", None)),
}


def to_json(msg) -> dict:
    """A JSON-able dict of an event: its fields plus ``type`` (arrays become nested lists)."""
    out = {"type": msg.type}
    for f in fields(msg):
        value = getattr(msg, f.name)
        if isinstance(value, np.ndarray):
            value = value.tolist()
        elif isinstance(value, tuple):
            value = [list(x) if isinstance(x, tuple) else x for x in value]
        out[f.name] = value
    return out
