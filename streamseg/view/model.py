"""What the view knows of every stream, built from the daemon's events and ``state`` replies.

Everything here is plain bookkeeping (no sockets, no web): :class:`Hub` applies decoded
protocol events and control snapshots in any order a late joiner can see them (cuts are
deduplicated by frame, ``segments`` of an older revision are ignored), keeps each stream's
history for pages opened later, and marks what changed so the server can coalesce updates.
"""

from __future__ import annotations

import bisect
import time

from streamseg.view.agreement import HumanLabels

MAX_CUTS = 20_000  # per stream, newest kept: a page never needs more to draw a timeline
MAX_SEGMENTS = 20_000
MAX_REPS = 20_000
MAX_CLOSED = 1000  # closed streams kept (oldest forgotten first), as many as the daemon keeps


class StreamView:
    """One stream as the page shows it.

    Attributes
    ----------
    cuts : list of dict
        Provisional cuts ``{frame, emitted_at, score}`` in emission order.
    segments : list of [start, end, label]
        The newest label of every frame relabelled so far: each ``segments`` event replaces
        what it covers (a relabel covers the last ``relabel_history`` seconds only).
    reps : list of [start, end, count]
    """

    def __init__(self, stream: str, now: float):
        self.stream = stream
        self.fps = None
        self.frame = 0  # newest frame known to have arrived (next expected)
        self.revision = 0
        self.seg_range = None  # [start, end) of the newest segments event
        self.cuts: list = []
        self.cut_frames: set = set()
        self.cut_base = 0  # cuts dropped from the front (cursor offsets stay valid)
        self.cut_version = 0  # + 1 per withdrawn cut: a page then redraws the stream whole
        self.segments: list = []
        self.seg_version = 0
        self.reps: list = []
        self.rep_base = 0
        self.errors: dict = {}
        self.gaps = 0
        self.closed = None
        self.ended = False  # the `closed` event came: later events are a new stream
        self.last_type = None
        self.last_at = None
        self.last_cut_lag = None  # s from a cut's frame to the frame that decided it
        self.fps_in = None
        self.buffer_fill = None
        self.events = 0
        self._rate_ref = None  # (uptime, frames_in) of the previous stats
        self.human: HumanLabels | None = None
        self.labels_error = None
        self.agreement = None
        self.created = now

    # --- applying ---------------------------------------------------------------------------

    def touch(self, kind: str, now: float) -> None:
        self.last_type, self.last_at = kind, now
        self.events += 1

    def add_cut(self, frame: int, emitted_at: int, score: float) -> bool:
        if frame in self.cut_frames:
            return False
        self.cut_frames.add(frame)
        self.cuts.append({"frame": frame, "emitted_at": emitted_at, "score": score})
        if len(self.cuts) > MAX_CUTS:
            drop = len(self.cuts) - MAX_CUTS
            for c in self.cuts[:drop]:
                self.cut_frames.discard(c["frame"])
            del self.cuts[:drop]
            self.cut_base += drop
        self.frame = max(self.frame, emitted_at + 1)
        if self.fps:
            self.last_cut_lag = (emitted_at - frame) / self.fps
        return True

    def withdraw_cut(self, frame: int) -> bool:
        """A pending cut was withdrawn (``withdraw`` event): it leaves the cut list."""
        if frame not in self.cut_frames:
            return False
        self.cut_frames.discard(frame)
        self.cuts = [c for c in self.cuts if c["frame"] != frame]
        self.cut_version += 1
        return True

    def add_segments(self, revision: int, start: int, end: int, segments) -> bool:
        if revision <= self.revision:
            return False
        self.revision = revision
        self.seg_range = [start, end]
        keep = []
        for a, b, lab in self.segments:  # what the new relabel does not cover stays
            if b <= start or a >= end:
                keep.append([a, b, lab])
            else:
                if a < start:
                    keep.append([a, start, lab])
                if b > end:
                    keep.append([end, b, lab])
        keep.extend([int(a), int(b), int(lab)] for a, b, lab in segments)
        keep.sort()
        self.segments = keep[-MAX_SEGMENTS:]
        self.seg_version += 1
        self.frame = max(self.frame, end)
        self._score()
        return True

    def add_rep(self, start: int, end: int, count: int) -> None:
        self.reps.append([start, end, count])
        if len(self.reps) > MAX_REPS:
            drop = len(self.reps) - MAX_REPS
            del self.reps[:drop]
            self.rep_base += drop
        self.frame = max(self.frame, end)

    def set_labels(self, labels: dict | None, reader=None) -> None:
        if not labels or self.human is not None or self.labels_error is not None:
            return
        try:
            self.human = (reader or HumanLabels.read)(labels["path"], labels["sequence"])
        except Exception as err:  # a missing or malformed file is shown, never fatal
            self.labels_error = f"labels {labels.get('path')!r} not read: {err}"
            return
        self._score()

    def _score(self) -> None:
        if self.human is not None and self.segments:
            self.agreement = self.human.agreement(self.segments, self.cuts, self.fps)

    def stats(self, uptime: float, st: dict) -> None:
        frames_in = st.get("frames_in")
        if isinstance(frames_in, int):
            ref = self._rate_ref
            if ref is not None and uptime > ref[0]:
                self.fps_in = (frames_in - ref[1]) / (uptime - ref[0])
            self._rate_ref = (uptime, frames_in)
        fill = st.get("buffer_fill")
        if isinstance(fill, (int, float)):
            self.buffer_fill = float(fill)
        if isinstance(st.get("frame"), int):
            self.frame = max(self.frame, st["frame"])

    # --- views ------------------------------------------------------------------------------

    def current_action(self):
        """``[label, since_frame]`` of the newest relabelled frame (consecutive segments of
        one label joined), or None before the first relabel."""
        if not self.segments:
            return None
        label = self.segments[-1][2]
        since = self.segments[-1][0]
        for a, _, lab in reversed(self.segments):
            if lab != label:
                break
            since = a
        return [label, since]

    def rep_count(self):
        return self.reps[-1][2] if self.reps else None

    def summary(self, now: float) -> dict:
        """The list row: identity and health."""
        return {
            "stream": self.stream,
            "fps": self.fps,
            "frame": self.frame,
            "fps_in": None if self.fps_in is None or self.closed else round(self.fps_in, 1),
            "lag": None if self.last_cut_lag is None else round(self.last_cut_lag, 3),
            "buffer_fill": self.buffer_fill,
            "errors": dict(self.errors),
            "gaps": self.gaps,
            "revision": self.revision,
            "cuts": self.cut_base + len(self.cuts),
            "action": self.current_action(),
            "reps": self.rep_count(),
            "closed": self.closed,
            "last": None
            if self.last_type is None
            else {"type": self.last_type, "at": round(self.last_at, 3)},
            "agreement": self.agreement,
            "labels_error": self.labels_error,
            "events": self.events,
            "created": round(self.created, 3),
        }

    def timeline(
        self, cut_from: int = 0, rep_from: int = 0, seg_version: int = -1, human: bool = True
    ) -> dict:
        """What a page needs to draw this stream, from the given cursors on (0 and -1: all);
        the human labels when ``human`` (the page does not have them yet) and they are known."""
        out = {
            "stream": self.stream,
            "fps": self.fps,
            "frame": self.frame,
            "cuts": self.cuts[max(0, cut_from - self.cut_base) :],
            "cut_next": self.cut_base + len(self.cuts),
            "reps": self.reps[max(0, rep_from - self.rep_base) :],
            "rep_next": self.rep_base + len(self.reps),
            "seg_version": self.seg_version,
            "cut_version": self.cut_version,
            "closed": self.closed,
            "revision": self.revision,
            "seg_range": self.seg_range,
        }
        if seg_version != self.seg_version:
            out["segments"] = self.segments
        if human and self.human is not None:
            out["human"] = self.human.rows
        return out


class Hub:
    """Every stream the view has heard of, and what changed since the last :meth:`take_dirty`.

    Parameters
    ----------
    clock : callable
        Wall clock (s), injectable for reproducible tests of the model.
    """

    def __init__(self, clock=time.time):
        self.clock = clock
        self.streams: dict[str, StreamView] = {}
        self.order: list[str] = []  # sorted ids (the page's list order)
        self.dirty: set = set()
        self.applied = 0  # events applied (the benchmark's forwarded count)
        self.totals: dict = {}
        self.uptime = None
        self.want_state: set = set()  # streams whose snapshot the feed should ask for
        self.closed_order: dict = {}  # closed stream ids, oldest first (insertion order)
        self.removed: set = set()  # forgotten since the last take_dirty
        self.max_closed = MAX_CLOSED

    def get(self, stream: str, fresh: bool = False) -> StreamView:
        sv = self.streams.get(stream)
        if sv is None or fresh:
            sv = StreamView(stream, self.clock())
            if stream not in self.streams:
                bisect.insort(self.order, stream)
                self.want_state.add(stream)
            self.streams[stream] = sv
        return sv

    def apply(self, ev) -> None:
        """Apply one decoded event (a :mod:`streamseg.protocol` message)."""
        self.applied += 1
        kind = ev.type
        if kind == "stats":
            self.uptime, self.totals = ev.uptime, ev.totals
            for stream, st in ev.streams.items():
                if isinstance(st, dict):
                    self.get(stream).stats(ev.uptime, st)
                    self.dirty.add(stream)
            return
        stream = getattr(ev, "stream", None)
        if stream is None:
            return  # a daemon-wide error: counted in the daemon's totals
        sv = self.get(stream)
        if sv.ended and kind != "closed" and kind != "error":
            sv = self.get(stream, fresh=True)  # re-announced: a new stream of the same id
            self.closed_order.pop(stream, None)
        now = self.clock()
        sv.touch(kind, now)
        if kind == "cut":
            sv.add_cut(ev.frame, ev.emitted_at, ev.score)
        elif kind == "withdraw":
            sv.withdraw_cut(ev.frame)
        elif kind == "segments":
            sv.add_segments(ev.revision, ev.start, ev.end, ev.segments)
        elif kind == "rep":
            sv.add_rep(ev.start, ev.end, ev.count)
        elif kind == "gap":
            sv.gaps += 1
        elif kind == "error":
            sv.errors[ev.reason] = max(ev.count, sv.errors.get(ev.reason, 0))
        elif kind == "closed":
            sv.closed, sv.ended = ev.reason, True
            sv.frame = max(sv.frame, ev.frames)
            self._closed(stream)
        self.dirty.add(stream)

    def apply_state(self, state: dict, reader=None) -> None:
        """Apply a control ``state`` reply (late join: the snapshot merges with events)."""
        stream = state.get("stream")
        if not isinstance(stream, str):
            return
        sv = self.get(stream)
        self.want_state.discard(stream)
        if isinstance(state.get("fps"), (int, float)):
            sv.fps = float(state["fps"])
        seg = state.get("segments")
        if isinstance(seg, dict):
            sv.add_segments(seg["revision"], seg["start"], seg["end"], seg["segments"])
        for c in state.get("cuts") or []:
            sv.add_cut(c["frame"], c["emitted_at"], c["score"])
        if sv.cuts and sv.fps:
            c = sv.cuts[-1]
            sv.last_cut_lag = (c["emitted_at"] - c["frame"]) / sv.fps
        if isinstance(state.get("frame"), int):
            sv.frame = max(sv.frame, state["frame"])
        if state.get("closed") and sv.closed is None:
            sv.closed = state["closed"]
            self._closed(stream)
        sv.set_labels(state.get("labels"), reader)
        self.dirty.add(stream)

    def lost(self, stream: str) -> None:
        """The daemon does not know this open stream any more (it restarted without a
        ``closed`` event): shown as closed, reason ``lost``."""
        sv = self.streams.get(stream)
        if sv is not None and sv.closed is None:
            sv.closed, sv.ended = "lost", True
            self._closed(stream)
            self.dirty.add(stream)

    def _closed(self, stream: str) -> None:
        self.closed_order.pop(stream, None)
        self.closed_order[stream] = None
        while len(self.closed_order) > self.max_closed:
            old = next(iter(self.closed_order))
            del self.closed_order[old]
            del self.streams[old]
            self.order.pop(bisect.bisect_left(self.order, old))
            self.dirty.discard(old)
            self.want_state.discard(old)
            self.removed.add(old)

    def take_dirty(self) -> tuple[list, list]:
        """``(changed, forgotten)`` stream ids since the last call."""
        out, gone = sorted(self.dirty), sorted(self.removed)
        self.dirty.clear()
        self.removed.clear()
        return out, gone

    def header(self) -> dict:
        """Daemon-wide figures for the page's header."""
        t = self.totals or {}
        return {
            "streams": len(self.streams),
            "open": sum(sv.closed is None for sv in self.streams.values()),
            "uptime": self.uptime,
            "applied": self.applied,
            "latency_p50_ms": t.get("latency_p50_ms"),
            "latency_p99_ms": t.get("latency_p99_ms"),
            "errors_by_reason": t.get("errors_by_reason", {}),
        }
