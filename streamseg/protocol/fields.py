"""Checks of single body fields: each raises a :class:`WireError` that names the field, the
value it got and what was expected."""

from __future__ import annotations

import math

from streamseg.protocol.messages import WireError, valid_stream_id


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
