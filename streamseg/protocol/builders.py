"""The message object of each type, built from an unpacked body whose fields are checked."""

from __future__ import annotations

from streamseg.protocol.arrays import frames_fields
from streamseg.protocol.fields import (
    MAX_INT,
    _flag,
    _int,
    _maybe_int,
    _need,
    _num,
    _pending,
    _stream,
)
from streamseg.protocol.messages import (
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
    Withdraw,
)
from streamseg.recording import UP_AXES


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
