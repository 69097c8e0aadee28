"""Protocol v1 messages: constants, topics, stream ids and the message dataclasses."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from streamseg.exceptions import ProtocolError

PROTOCOL_VERSION = 1
INGEST_TYPES = ("announce", "frames", "end")
CHANGING_OPS = ("shutdown", "checkpoint")  # control ops that need CURVE or the control token
EVENT_TYPES = ("cut", "confirm", "withdraw", "segments", "rep", "gap", "error", "stats", "closed")
DAEMON_WIDE = "*"
# a stream resumed after a crash continues its event numbers this far on: the events of the
# moments before the crash may not have reached the log, and their numbers are never reused
SEQ_SKIP = 1000
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


# The event sequence number (docs/protocol.md, "Sequence numbers"): set by the daemon when it
# publishes, so it is not part of an event's identity (two runs' events compare equal).
def _seq():
    return field(default=None, compare=False)


@dataclass(frozen=True)
class Announce:
    """Ingest: a stream starts. ``parents[j]`` is the index of joint j's parent, -1 for roots."""

    stream: str
    fps: float
    joints: tuple[str, ...]
    parents: tuple[int, ...]
    units: str = "mm"
    up: str = "y"
    labels: str | None = None  # optional: path of a human label CSV for this recording
    labels_sequence: str | None = None  # its rows to use (default: the stream id)
    auth: str | None = None  # the control token: may re-announce a stream of another client

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
        return (
            self.stream == other.stream
            and self.seq == other.seq
            and _same_float(self.timestamp, other.timestamp)
            and self.positions.dtype == other.positions.dtype
            and self.positions.shape == other.positions.shape
            and np.array_equal(self.positions, other.positions, equal_nan=True)
        )

    __hash__ = None


@dataclass(frozen=True)
class End:
    """Ingest: the stream is over; the daemon publishes final events and a ``closed`` event."""

    stream: str
    auth: str | None = None  # the control token: may end a stream of another client

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
    # True: an early decision a later ``confirm`` or ``withdraw`` settles (two-stage
    # detector); None (left out on the wire): final when emitted
    pending: bool | None = None
    # with ``provisional`` false: the ``segments`` revision whose boundary this cut announces
    revision: int | None = None
    seq: int | None = _seq()

    type = "cut"


@dataclass(frozen=True)
class Confirm:
    """Event: the pending cut at ``frame`` stands (the confirming stage decided the same
    cut at ``emitted_at``, LOF ``score``); with ``settled``: the provisional cut at ``frame``
    is settled by the relabel ``revision``, the boundary at frame ``settled``."""

    stream: str
    frame: int
    time: float
    score: float
    emitted_at: int
    settled: int | None = None
    revision: int | None = None
    seq: int | None = _seq()

    type = "confirm"


@dataclass(frozen=True)
class Withdraw:
    """Event: the pending cut at ``frame`` is taken back (decided at ``emitted_at``);
    ``moved``: a cut nearby follows (the confirming stage placed it at another frame). With
    ``revision``: the provisional cut at ``frame`` is withdrawn by that relabel (it found no
    boundary there)."""

    stream: str
    frame: int
    time: float
    emitted_at: int
    moved: bool = False
    revision: int | None = None
    seq: int | None = _seq()

    type = "withdraw"


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
    seq: int | None = _seq()

    type = "segments"


@dataclass(frozen=True)
class Rep:
    """Event: a repetition in frames ``[start, end)``, the ``count``-th of the current set,
    found when frame ``emitted_at`` arrived; ``label`` is the action label of the segment it
    belongs to (None until a relabel covers it), ``set_index`` the set's index in the stream
    (0-based; the count restarts at a new set). What a therapist or coach reads of it, as
    ``segment --method rep --json`` gives it: ``duration_s`` (seconds), ``rom_deg`` (range of
    motion of the set's most moving joint ``rom_joint`` in this repetition, degrees) and
    ``likeness`` (to the repetition before it, 1 = the same, 0 = at the limit of alike); None
    where the counter has none (feature rows without joints) or the sender is older."""

    stream: str
    start: int
    end: int
    count: int
    time: float
    emitted_at: int = 0
    label: int | None = None
    set_index: int = 0
    duration_s: float | None = None
    rom_deg: float | None = None
    rom_joint: str | None = None
    likeness: float | None = None
    seq: int | None = _seq()

    type = "rep"


@dataclass(frozen=True)
class Gap:
    """Event: frames ``[expected, got)`` of a stream have no positions: they never arrived
    (lost), or came without the joints the features use. ``filled``: True when the gap was
    short enough to be filled by interpolation (the detectors saw the filled frames), False
    when the detectors skip it; None from a sender of the field's absence (older daemons)."""

    stream: str
    expected: int
    got: int
    filled: bool | None = None
    seq: int | None = _seq()

    type = "gap"


@dataclass(frozen=True)
class Error:
    """Event: bad input. ``count`` is how many times ``reason`` happened for ``stream``."""

    stream: str | None
    reason: str
    message: str
    count: int = 1
    seq: int | None = _seq()

    type = "error"


@dataclass(frozen=True)
class Stats:
    """Event: heartbeat. ``totals`` daemon-wide counters; ``streams`` per-stream counters;
    ``last_seq`` the last event number published of every open stream, of ``*`` and of each
    stream closed since the previous heartbeat (a subscriber that holds less lost the rest:
    it fetches it with the control op ``since``)."""

    uptime: float
    totals: dict = field(default_factory=dict)
    streams: dict = field(default_factory=dict)
    last_seq: dict = field(default_factory=dict)

    type = "stats"


@dataclass(frozen=True)
class Closed:
    """Event: a stream's state was dropped (``reason``: end, idle, shutdown) after ``frames``."""

    stream: str
    reason: str
    frames: int
    seq: int | None = _seq()

    type = "closed"


@dataclass(frozen=True)
class Hello:
    """Event: the answer to a control ``hello`` request, published on topic
    ``hello/<token>/``. A subscriber that receives its token knows its subscription is live
    (ZeroMQ drops what a PUB socket sends before a subscription arrives)."""

    token: str

    type = "hello"


MESSAGES = {
    cls.type: cls
    for cls in (
        Announce,
        Frames,
        End,
        Cut,
        Confirm,
        Withdraw,
        Segments,
        Rep,
        Gap,
        Error,
        Stats,
        Closed,
        Hello,
    )
}


def _same_float(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


# --- encoding ------------------------------------------------------------------------------
