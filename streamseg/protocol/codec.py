"""Protocol v1 codec: encode messages to ``[topic, body]`` frames, decode and validate them.

The checks of single fields are in :mod:`~streamseg.protocol.fields`, arrays and the
``frames`` fast path in :mod:`~streamseg.protocol.arrays`, the message object of each type in
:mod:`~streamseg.protocol.builders`.
"""

from __future__ import annotations

from dataclasses import fields, replace

import msgpack
import numpy as np

from streamseg.protocol.arrays import decode_array, encode_array, frames_fields
from streamseg.protocol.builders import _BUILDERS
from streamseg.protocol.fields import MAX_INT, _int, _short
from streamseg.protocol.messages import MESSAGES, PROTOCOL_VERSION, WireError, topic

__all__ = [
    "MAX_INT",
    "decode",
    "decode_array",
    "encode",
    "encode_array",
    "frames_fields",
    "from_body",
    "to_json",
    "unpack_body",
]

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
