"""Per-stream bookkeeping of the daemon and the error ledger (no algorithm code)."""

from __future__ import annotations

import collections
import logging
from typing import NamedTuple

import numpy as np

from streamseg import protocol
from streamseg.state import Stateful

log = logging.getLogger("streamseg.daemon")

RECENT_CUTS = 256  # cuts kept per stream for a late joiner's catch-up (after the last relabel)


class Closing(NamedTuple):
    """A take that ended and waits for its final relabel (``job``) before its ``closed``."""

    st: StreamState
    reason: str
    job: object  # the RelabelJob, waiting in the relabel queue or the worker's


class StreamState(Stateful):
    """What the daemon knows about one live stream.

    ``pipeline`` does the computing; everything here is counters, sequence tracking and the
    latest published state a late joiner needs (Clone pattern: snapshot + revision).
    """

    # the pipeline is stored beside it; per-drain buffers and the rate limit start anew
    _transient = ("pipeline", "pending", "arrivals", "gap_limit")
    __slots__ = (
        "stream",
        "gen",
        "fps",
        "pipeline",
        "next_seq",
        "t0",
        "last_seen",
        "frames_in",
        "dropped",
        "lost",
        "events_out",
        "revision",
        "segments",
        "cuts",
        "reps",
        "next_relabel",
        "relabel_time",
        "pending",
        "arrivals",
        "labels",
        "gap_limit",
        "seq_base",
        "client",
    )

    def __init__(self, stream: str, gen: int, fps: float, pipeline, now: float):
        self.stream = stream
        self.gen = gen
        self.fps = fps
        self.pipeline = pipeline
        self.next_seq = 0
        self.t0 = None  # sender clock at frame 0
        self.last_seen = now
        self.frames_in = 0
        self.dropped = 0
        self.lost = 0
        self.events_out = 0
        self.revision = 0
        self.segments = None  # last Segments event
        self.cuts = collections.deque(maxlen=RECENT_CUTS)
        self.reps = 0
        self.next_relabel = 0
        self.relabel_time = 0.0
        self.pending = []  # Frames packets its pipeline has not had yet, contiguous
        self.arrivals = []  # perf_counter() at which each pending packet was received
        self.labels = None  # {"path", "sequence"} of human labels the announce named
        self.gap_limit = None  # limits.RateLimit of published gap events
        self.seq_base = 0  # the stream id's last event number before this stream opened
        self.client = None  # who announced it (the per-client quota)

    def time_of(self, frame: int) -> float:
        return (self.t0 or 0.0) + frame / self.fps

    def stats(self) -> dict:
        return {
            "frames_in": self.frames_in,
            "dropped": self.dropped,
            "lost": self.lost,
            "events_out": self.events_out,
            "buffer_fill": round(self.pipeline.fill, 4),
            "relabel_time": round(self.relabel_time, 6),
            "revision": self.revision,
            "frame": self.next_seq,
        }

    def state(self) -> dict:
        """The catch-up state of the control endpoint's ``state`` request."""
        seg = self.segments
        return {
            "stream": self.stream,
            "fps": self.fps,
            "frame": self.next_seq,
            "revision": self.revision,
            "seq_base": self.seq_base,
            "segments": None if seg is None else protocol.to_json(seg),
            "cuts": [protocol.to_json(c) for c in self.cuts if seg is None or c.frame >= seg.end],
            **({"labels": self.labels} if self.labels else {}),
        }


class LatencyRing:
    """The last ``size`` packet latencies (arrival -> its events published), in seconds."""

    def __init__(self, size: int = 1 << 16):
        self.values = np.zeros(size)
        self.count = 0

    def add(self, lat: np.ndarray) -> None:
        size = self.values.shape[0]
        lat = lat[-size:]
        idx = (self.count + np.arange(lat.shape[0])) % size
        self.values[idx] = lat
        self.count += lat.shape[0]

    def reset(self) -> None:
        self.count = 0

    def percentiles(self, q=(50, 99)) -> list:
        n = min(self.count, self.values.shape[0])
        if n == 0:
            return [None for _ in q]
        return [float(v) for v in np.percentile(self.values[:n], q)]


class ErrorBook:
    """Counts bad input per (stream, reason); logs and publishes the first of each at once.

    Later occurrences are only counted and republished (with the new count) at most once per
    heartbeat by :meth:`due`, so a flood of garbage costs a counter increment each.
    """

    MAX_KEYS = 100_000  # beyond this, further streams' errors are pooled under stream None

    def __init__(self):
        self.counts: dict = {}
        self.dirty: dict = {}
        self.total = 0

    def add(self, stream, reason: str, message: str, n: int = 1):
        """Count an error; returns the Error event to publish now, or None."""
        self.total += n
        key = (stream, reason)
        if key not in self.counts and len(self.counts) >= self.MAX_KEYS:
            key = (None, reason)
        count = self.counts.get(key, 0) + n
        self.counts[key] = count
        if count == n:
            log.warning(
                "stream %s: %s: %s (logged once per stream and kind; counted after)",
                key[0] if key[0] is not None else "?",
                reason,
                message,
            )
            return protocol.Error(key[0], reason, message, count)
        self.dirty[key] = message
        return None

    def due(self) -> list:
        """Error events with updated counts for the keys that grew since the last call."""
        out = [protocol.Error(k[0], k[1], msg, self.counts[k]) for k, msg in self.dirty.items()]
        self.dirty.clear()
        return out

    def due_for(self, stream) -> list:
        """:meth:`due` for one stream only (published before its ``closed`` event)."""
        keys = [k for k in self.dirty if k[0] == stream]
        return [protocol.Error(k[0], k[1], self.dirty.pop(k), self.counts[k]) for k in keys]

    def by_reason(self) -> dict:
        out: dict = {}
        for (_, reason), c in self.counts.items():
            out[reason] = out.get(reason, 0) + c
        return out
