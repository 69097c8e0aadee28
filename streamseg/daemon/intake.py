"""The stream table and what turns ingest packets into stream work.

:class:`Intake` takes the receiver's queue (:mod:`streamseg.daemon.ingest`), handles
announce and ``end``, keeps the open streams (who owns each, the per-client quota), sequences
frames (gaps, duplicates, limits) and runs each stream's pipeline on what it got, several
packets in one step (the vectorised path; while the loop is busy, a stream's frames wait for
more of their own, bounded in frames and time). What it publishes, and a stream's closing
(the final relabel), go through an :class:`Outbox`, the daemon.
"""

from __future__ import annotations

import collections
import logging
import time
from typing import Protocol

import numpy as np

from streamseg import protocol
from streamseg.daemon import limits
from streamseg.daemon.ingest import BodyItem, FramesItem
from streamseg.daemon.options import skeleton_from
from streamseg.daemon.pipeline import StreamPipeline
from streamseg.daemon.security import peer_of
from streamseg.daemon.streams import LatencyRing, StreamState
from streamseg.protocol.auth import matches

log = logging.getLogger("streamseg.daemon")


SLICE_S = 0.02  # s: the longest the loop spends on ingest before it serves the rest
LOAD_WINDOW_S = 0.25  # s: the loop's load is judged over windows this long


class Outbox(Protocol):
    """What the intake asks of the daemon (the loop thread)."""

    def publish(self, st: StreamState | None, ev) -> object:
        """Number, log and publish an event."""

    def error(self, stream, reason: str, message: str, n: int = 1) -> None:
        """Count and report a problem (an ``error`` event, rate limited)."""

    def notices(self, st: StreamState) -> None:
        """Publish the pipeline's notices (problems that do not stop the stream)."""

    def results(self, st: StreamState, cuts, reps) -> None:
        """Publish a pipeline step's cuts and repetitions."""

    def opened(self, st: StreamState) -> None:
        """A take opened (its events may wait for an older take of its id)."""

    def close(self, st: StreamState, reason: str) -> None:
        """Close a take: final cuts, final relabel, ``closed``."""

    def flushed(self, st: StreamState) -> None:
        """A stream's pipeline ran on new frames (a relabel may be due)."""


class Intake:
    """The open streams and the handling of every ingest message.

    Parameters
    ----------
    config : streamseg.config.DaemonConfig
        Limits (``max_streams``, quotas, ``drain``, ...), ``relabel_interval``.
    algorithms : streamseg.daemon.algorithms.Algorithms
        What each stream's pipeline runs.
    ingest : streamseg.daemon.ingest.Ingest
        The receiver's queue.
    out : Outbox
        The daemon: publication and closing.
    errors : streamseg.daemon.streams.ErrorBook
        Where gaps are counted.
    numbering : streamseg.daemon.eventlog.Numbering
        A new take's history starts after its id's last event number.
    default_skeleton : streamseg.daemon.options.Skeleton, optional
        For frames of streams that were never announced.

    Notes
    -----
    :meth:`owners` must be called once the security is known (at bind).
    """

    def __init__(
        self, config, algorithms, ingest, out: Outbox, errors, numbering, default_skeleton=None
    ):
        self.config, self.algorithms, self.ingest, self.out = config, algorithms, ingest, out
        self.errors, self.numbering, self.default_skeleton = errors, numbering, default_skeleton
        self.streams: dict[str, StreamState] = {}
        self.clients = collections.Counter()  # open streams per client (the quota)
        self.joined: set = set()  # (stream, gen) opened by a subscription, no frame yet
        self.latency = LatencyRing()
        self.n_packets = self.n_frames = 0  # plain ints: updated per packet
        self.n_steps = 0  # pipeline steps (each on one stream's frames held till then)
        self.gen = 0  # the last take's generation
        self.curve = False  # CURVE authenticates clients (their key owns a stream)
        self.token = None  # without CURVE, the control token may end any stream
        self._dirty: dict = {}  # streams holding frames their pipeline has not had (ordered)
        self._loaded = config.coalesce_load == 0  # busy in the last LOAD_WINDOW_S
        self._window, self._busy = time.perf_counter(), 0.0  # the current window's start, work
        self._sender = None  # topic frame of the message being handled (its identity)

    def owners(self, curve: bool, token: str | None) -> None:
        """Who owns a stream: its CURVE key (``curve``) or its connection; ``token`` lets
        the daemon's user end or re-announce any stream without CURVE."""
        self.curve, self.token = curve, token

    def take(self, now: float) -> None:
        """Handle the messages the receiver thread queued (at most ``drain`` packets and
        ``drain_frames`` frames, and no more once :data:`SLICE_S` of work is done), then run
        each stream's pipeline once on what it got."""
        c = self.config
        # packets that each run a pipeline (a gap in every one) can cost a millisecond each:
        # the loop answers control requests and beats between slices of them
        started = time.perf_counter()
        until = started + SLICE_S
        for it in self.ingest.take(c.drain, c.drain_frames, until):
            self.n_packets += 1
            try:
                if type(it) is FramesItem:
                    st = self.streams.get(it.stream)
                    if st is None or st.client is None:
                        self._sender = it.sender
                        if st is None:
                            st = self._unannounced(it.stream, now)
                            if st is None:
                                continue
                    self._on_frames(st, it.seq, it.timestamp, it.positions, now, it.arrival)
                elif type(it) is BodyItem:
                    self._sender = it.sender
                    self._on_body(it.body, now, 0.0, it.subscribed)
                else:
                    self.out.error(it.stream, it.reason, it.message)
            except protocol.WireError as err:
                self.out.error(err.stream, err.kind, str(err))
            except Exception as err:  # a packet validation missed must not stop the daemon
                self.out.error(
                    None, "decode", f"packet could not be handled ({type(err).__name__}: {err})"
                )
        self._flush_due(started)

    def _flush_due(self, started: float) -> None:
        """Run the pipeline of each stream whose frames should not wait longer.

        A stream's pipeline step costs about as much for one packet as for ten
        (docs/decisions.md, Coalescing). While the loop has room, every stream's frames go on
        at once; once it was busy more than ``coalesce_load`` of the last
        :data:`LOAD_WINDOW_S`, a stream's frames wait for more of their own,
        ``coalesce_frames`` or ``coalesce_wait`` seconds at most, so more streams cost fewer
        steps.
        """
        c = self.config
        if self._dirty:
            if self._loaded and c.coalesce_wait > 0:
                oldest = time.perf_counter() - c.coalesce_wait
                due = [
                    st
                    for st in self._dirty
                    if st.arrivals[0] <= oldest
                    or sum(a.shape[0] for a in st.pending) >= c.coalesce_frames
                ]
            else:
                due = list(self._dirty)
            for st in due:
                self.flush(st)
        end = time.perf_counter()
        self._busy += end - started
        if end - self._window >= LOAD_WINDOW_S:
            self._loaded = self._busy >= c.coalesce_load * (end - self._window)
            self._window, self._busy = end, 0.0

    def wait_ms(self, longest: int) -> int:
        """Milliseconds the loop may wait for messages before frames held back are due
        (at most ``longest``)."""
        if not self._dirty:
            return longest
        # streams enter _dirty in the order of their oldest held frame: the first is due first
        first = next(iter(self._dirty)).arrivals[0]
        due = first + self.config.coalesce_wait - time.perf_counter()
        return max(0, min(longest, int(due * 1e3) + 1))

    def take_queued(self) -> None:
        """Stop reading and process every message already received."""
        self.ingest.stop()
        while self.ingest.items:
            self.take(time.monotonic())

    def remove(self, st: StreamState) -> None:
        """``st`` leaves the table (it is closing): its pending frames processed first."""
        self.flush(st)
        del self.streams[st.stream]
        self._release(st)

    def _release(self, st: StreamState) -> None:
        if st.client is not None:
            self.clients[st.client] -= 1
            if not self.clients[st.client]:
                del self.clients[st.client]

    def restored(self, st: StreamState, now: float) -> None:
        """A stream restored from a checkpoint joins the table as a new take. Without CURVE
        the connection that announced it is gone with the old process: the first connection
        that sends it frames again becomes its owner (:meth:`_adopt`)."""
        self.gen += 1
        st.gen = self.gen
        st.pending, st.arrivals = [], []
        st.gap_limit = limits.RateLimit(self.config.gap_events_per_s)
        st.last_seen = now
        if not self.curve:
            st.client = None
        self.streams[st.stream] = st
        if st.client is not None:
            self.clients[st.client] += 1

    def _on_body(self, obj: dict, now: float, arrival: float, subscribed: bool = False) -> None:
        """Dispatch one unpacked ingest body (envelope checked); raises WireError."""
        kind = obj["type"]
        stream = obj.get("stream")
        if kind == "frames":
            st = self.streams.get(stream) if type(stream) is str else None
            if st is None:
                st = self._unannounced(stream, now)
                if st is None:
                    return
            self._on_frames(st, *protocol.frames_fields(obj, stream), now, arrival)
        elif kind == "announce":
            self._on_announce(protocol.from_body(obj), now, subscribed)
        elif kind == "end":
            msg = protocol.from_body(obj)
            st = self.streams.get(msg.stream)
            if st is None:
                self.out.error(msg.stream, "unknown_stream", "end of a stream that is not open")
            elif self._owns(st, msg.auth, "end"):
                self.out.close(st, "end")
        else:
            self.out.error(
                stream if isinstance(stream, str) else None,
                "type",
                f"{kind} is an event type; the ingest socket takes "
                f"{', '.join(protocol.INGEST_TYPES)}",
            )

    def _unannounced(self, stream, now):
        if not protocol.valid_stream_id(stream):
            self.out.error(None, "field", f"frames.stream={stream!r} is not a valid stream id")
        elif self.default_skeleton is not None:
            return self._open(stream, self.config.default_fps, self.default_skeleton, now)
        else:
            self.out.error(
                stream,
                "unknown_stream",
                "frames for a stream that was not announced "
                "(send an announce message first, or configure default_skeleton)",
            )
        return None

    def _on_announce(self, msg: protocol.Announce, now: float, subscribed: bool = False) -> None:
        problem = limits.fps_problem(msg.fps, self.config)
        if problem:
            self.out.error(msg.stream, "field", problem)
            return
        old = self.streams.get(msg.stream)
        if subscribed and old is not None and _same_take(old, msg):
            # a publisher announces its streams again and again, for subscribers that join
            # late (docs/protocol.md, Subscribing): the same announce is no new take
            old.last_seen = now
            return
        if old is not None:
            if not self._owns(old, msg.auth, "re-announce"):
                return
            self.out.close(old, "reannounced")
        skeleton = skeleton_from(msg.joints, msg.parents, msg.units, msg.up)
        st = self._open(msg.stream, msg.fps, skeleton, now)
        if st is not None and subscribed:
            # joined on a publisher's announce, perhaps long into its take: the take starts
            # at the first frame this daemon receives, not at frame 0 (docs/protocol.md)
            self.joined.add((st.stream, st.gen))
        if st is not None and msg.labels:  # passed on to subscribers through `state`
            st.labels = {"path": msg.labels, "sequence": msg.labels_sequence or msg.stream}

    def _adopt(self, st: StreamState) -> None:
        st.client = peer_of(self._sender) if self._sender is not None else None
        if st.client is not None:
            self.clients[st.client] += 1

    def _owns(self, st: StreamState, auth, what: str) -> bool:
        """Whether the sender of the message being handled may end or re-announce ``st``: the
        client that announced it (its CURVE key, else its connection), or without CURVE one
        that shows the control token (the daemon's user). Else an ``owner`` error."""
        if st.client is None or peer_of(self._sender) == st.client:
            return True
        if not self.curve and matches(auth, self.token):
            return True
        how = (
            "its CURVE key"
            if self.curve
            else "its connection, or the control token of the daemon's user"
        )
        self.out.error(
            st.stream,
            "owner",
            f"{what} refused: stream {st.stream} belongs to the "
            f"client that announced it ({how}); send under another stream id",
        )
        return False

    def _open(self, stream, fps, skeleton, now):
        if len(self.streams) >= self.config.max_streams:
            self.out.error(
                stream,
                "max_streams",
                f"{len(self.streams)} streams are open, the "
                f"configured maximum (max_streams); close one or raise the limit",
            )
            return None
        quota = self.config.max_streams_per_client
        client = peer_of(self._sender) if self._sender is not None else None
        if quota and client is not None and self.clients[client] >= quota:
            self.out.error(
                stream,
                "quota",
                f"this client ({client[:12]}) holds {quota} open "
                f"streams, its quota (max_streams_per_client); end one first",
            )
            return None
        try:
            pipeline = StreamPipeline(skeleton, fps, self.algorithms, self.config.relabel_history)
        except Exception as err:  # e.g. a skeleton without the joints the features need
            self.out.error(stream, "skeleton", f"cannot segment this stream: {err}")
            return None
        self.gen += 1
        st = StreamState(stream, self.gen, fps, pipeline, now)
        st.next_relabel = int(round(self.config.relabel_interval * fps))
        st.gap_limit = limits.RateLimit(self.config.gap_events_per_s)
        st.seq_base = self.numbering.current(stream)
        st.client = client
        if client is not None:
            self.clients[client] += 1
        self.streams[stream] = st
        log.info("stream %s open: %.4g fps, %d joints", stream, fps, skeleton.n_joints)
        self.out.opened(st)
        return st

    def _on_frames(
        self,
        st: StreamState,
        seq: int,
        timestamp: float,
        pos: np.ndarray,
        now: float,
        arrival: float,
    ) -> None:
        n, n_joints = pos.shape[0], pos.shape[1]
        st.last_seen = now
        if st.client is None:  # restored from a checkpoint: its sender takes it back
            self._adopt(st)
        if n_joints != st.pipeline.skeleton.n_joints or n > self.config.max_packet_frames:
            st.dropped += n
            self.out.error(
                st.stream,
                "array",
                f"packet of shape {list(pos.shape)}: expected "
                f"(n <= {self.config.max_packet_frames}, "
                f"{st.pipeline.skeleton.n_joints}, 3) as announced",
            )
            return
        problem = limits.clock_problem(timestamp) or (
            seq > st.next_seq
            and limits.jump_problem(seq, st.next_seq, st.fps, self.config.max_seq_jump)
        )
        if problem:
            st.dropped += n
            self.out.error(st.stream, "seq" if seq > st.next_seq else "field", problem)
            return
        if self.joined and st.frames_in == 0 and (st.stream, st.gen) in self.joined:
            self.joined.discard((st.stream, st.gen))
            st.next_seq = seq
            st.pipeline.start_at(seq)
        if st.t0 is None:
            st.t0 = timestamp - seq / st.fps
        if seq != st.next_seq:
            if seq > st.next_seq:
                self.flush(st)  # the segmenter learns contiguous runs
                st.lost += seq - st.next_seq
                self.errors.add(st.stream, "gap", f"frames {st.next_seq}..{seq - 1} missing")
                if st.gap_limit.allow(now):  # the rest are counted in the `gap` error
                    filled = seq - st.next_seq <= st.pipeline.fill_frames
                    self.out.publish(st, protocol.Gap(st.stream, st.next_seq, seq, filled))
            else:
                overlap = st.next_seq - seq
                st.dropped += min(overlap, n)
                self.out.error(
                    st.stream,
                    "duplicate",
                    f"packet at frame {seq} repeats frames "
                    f"already received (next expected {st.next_seq})",
                    min(overlap, n),
                )
                if overlap >= n:
                    return
                pos = pos[overlap:]
                n -= overlap
        st.pending.append(pos)
        st.arrivals.append(arrival)
        st.next_seq = st.next_seq + n if seq < st.next_seq else seq + n
        st.frames_in += n
        self.n_frames += n
        self._dirty[st] = None

    def report_gaps(self, st: StreamState, bad: int) -> None:
        """Frames skipped without positions (``nan``), and a ``gap`` event (not filled) for
        each gap of frames that came without the features' joints, longer than the gap
        filler fills (docs/guide/formats.md, Gaps)."""
        if bad:
            st.dropped += bad
            self.out.error(
                st.stream,
                "nan",
                "frames without the joint positions the features "
                "use, in gaps too long to fill: skipped",
                bad,
            )
        for start, end in st.pipeline.gaps:
            if st.gap_limit.allow(time.monotonic()):
                self.out.publish(st, protocol.Gap(st.stream, start, end, False))
        st.pipeline.gaps.clear()

    def flush(self, st: StreamState) -> None:
        """Run ``st``'s pipeline on the frames it holds and publish what it found."""
        self._dirty.pop(st, None)
        if not st.pending:
            return
        arrays, arrivals = st.pending, st.arrivals
        st.pending, st.arrivals = [], []
        pos = arrays[0] if len(arrays) == 1 else np.concatenate(arrays)
        first = st.next_seq - pos.shape[0]
        self.n_steps += 1
        try:
            cuts, reps, bad = st.pipeline.push(pos, first)
        except Exception as err:  # never die on input: report and drop these frames
            st.dropped += pos.shape[0]
            self.out.error(
                st.stream,
                "pipeline",
                f"{pos.shape[0]} frames from {first} not processed: {type(err).__name__}: {err}",
                pos.shape[0],
            )
            return
        self.out.notices(st)
        self.report_gaps(st, bad)
        self.out.results(st, cuts, reps)
        self.latency.add(time.perf_counter() - np.array(arrivals))
        self.out.flushed(st)


def _same_take(st: StreamState, msg: protocol.Announce) -> bool:
    """Whether ``msg`` announces the open take ``st`` again (rate and skeleton alike)."""
    sk = st.pipeline.skeleton
    return (
        msg.fps == st.fps
        and tuple(msg.joints) == tuple(sk.names)
        and list(msg.parents) == [int(p) for p in sk.parents]
    )
