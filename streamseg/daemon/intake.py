"""How the daemon's loop turns ingest packets into stream work (a part of :class:`Daemon`).

Taking the receiver's queue (:mod:`streamseg.daemon.ingest`), announce and the stream table,
frame sequencing (gaps, duplicates, limits) and the vectorised per-stream flush that
publishes cuts and repetitions.
The loop, sockets, publication, relabel results and shutdown stay in
:mod:`streamseg.daemon.server`.
"""

from __future__ import annotations

import logging
import time

import numpy as np

from streamseg import protocol
from streamseg.daemon import limits
from streamseg.daemon.ingest import BodyItem, FramesItem
from streamseg.daemon.options import skeleton_from
from streamseg.daemon.pipeline import StreamPipeline
from streamseg.daemon.security import peer_of
from streamseg.daemon.streams import StreamState
from streamseg.protocol.auth import matches

log = logging.getLogger("streamseg.daemon")


class Intake:
    """The ingest half of :class:`~streamseg.daemon.server.Daemon` (a mixin: it uses the
    daemon's sockets, stream table, counters and publication methods)."""

    def _take(self, now: float) -> None:
        """Handle the messages the receiver thread queued (at most ``drain`` packets and
        ``drain_frames`` frames), then run each stream's pipeline once on what it got."""
        c = self.config
        for it in self.ingest.take(c.drain, c.drain_frames):
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
                    self._error(it.stream, it.reason, it.message)
            except protocol.WireError as err:
                self._error(err.stream, err.kind, str(err))
            except Exception as err:  # a packet validation missed must not stop the daemon
                self._error(None, "decode", f"packet could not be handled "
                            f"({type(err).__name__}: {err})")
        for st in self._dirty:
            self._flush(st)
        self._dirty.clear()

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
                self._error(msg.stream, "unknown_stream", "end of a stream that is not open")
            elif self._owns(st, msg.auth, "end"):
                self._close(st, "end")
        else:
            self._error(stream if isinstance(stream, str) else None, "type",
                        f"{kind} is an event type; the ingest socket takes "
                        f"{', '.join(protocol.INGEST_TYPES)}")

    def _unannounced(self, stream, now):
        if not protocol.valid_stream_id(stream):
            self._error(None, "field", f"frames.stream={stream!r} is not a valid stream id")
        elif self.default_skeleton is not None:
            return self._open(stream, self.config.default_fps, self.default_skeleton, now)
        else:
            self._error(stream, "unknown_stream", "frames for a stream that was not announced "
                        "(send an announce message first, or configure default_skeleton)")
        return None

    def _on_announce(self, msg: protocol.Announce, now: float, subscribed: bool = False) -> None:
        problem = limits.fps_problem(msg.fps, self.config)
        if problem:
            self._error(msg.stream, "field", problem)
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
            self._close(old, "reannounced")
        skeleton = skeleton_from(msg.joints, msg.parents, msg.units, msg.up)
        st = self._open(msg.stream, msg.fps, skeleton, now)
        if st is not None and subscribed:
            # joined on a publisher's announce, perhaps long into its take: the take starts
            # at the first frame this daemon receives, not at frame 0 (docs/protocol.md)
            self.joined.add((st.stream, st.gen))
        if st is not None and msg.labels:  # passed on to subscribers through `state`
            st.labels = {"path": msg.labels, "sequence": msg.labels_sequence or msg.stream}

    def _restored_owners(self) -> None:
        """Streams restored from checkpoints keep their CURVE key as owner; without CURVE the
        connection that announced one is gone with the old process: the first connection that
        sends it frames again becomes its owner (:meth:`_adopt`)."""
        if self.security is not None:
            return
        for st in self.streams.values():
            if st.client is not None:
                self.clients[st.client] -= 1
                if not self.clients[st.client]:
                    del self.clients[st.client]
                st.client = None

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
        if self.security is None and matches(auth, self.token):
            return True
        how = ("its CURVE key" if self.security is not None else
               "its connection, or the control token of the daemon's user")
        self._error(st.stream, "owner", f"{what} refused: stream {st.stream} belongs to the "
                    f"client that announced it ({how}); send under another stream id")
        return False

    def _open(self, stream, fps, skeleton, now):
        if len(self.streams) >= self.config.max_streams:
            self._error(stream, "max_streams", f"{len(self.streams)} streams are open, the "
                        f"configured maximum (max_streams); close one or raise the limit")
            return None
        quota = self.config.max_streams_per_client
        client = peer_of(self._sender) if self._sender is not None else None
        if quota and client is not None and self.clients[client] >= quota:
            self._error(stream, "quota", f"this client ({client[:12]}) holds {quota} open "
                        f"streams, its quota (max_streams_per_client); end one first")
            return None
        try:
            pipeline = StreamPipeline(skeleton, fps, self.algorithms, self.config.relabel_history)
        except Exception as err:  # e.g. a skeleton without the joints the features need
            self._error(stream, "skeleton", f"cannot segment this stream: {err}")
            return None
        self._gen += 1
        st = StreamState(stream, self._gen, fps, pipeline, now)
        st.next_relabel = int(round(self.config.relabel_interval * fps))
        st.gap_limit = limits.RateLimit(self.config.gap_events_per_s)
        st.seq_base = self.numbering.current(stream)
        st.client = client
        if client is not None:
            self.clients[client] += 1
        self.streams[stream] = st
        self.totals["streams_opened"] += 1
        log.info("stream %s open: %.4g fps, %d joints", stream, fps, skeleton.n_joints)
        return st

    def _on_frames(self, st: StreamState, seq: int, timestamp: float, pos: np.ndarray,
                   now: float, arrival: float) -> None:
        n, n_joints = pos.shape[0], pos.shape[1]
        st.last_seen = now
        if st.client is None:  # restored from a checkpoint: its sender takes it back
            self._adopt(st)
        if n_joints != st.pipeline.skeleton.n_joints or n > self.config.max_packet_frames:
            st.dropped += n
            self._error(st.stream, "array", f"packet of shape {list(pos.shape)}: expected "
                        f"(n <= {self.config.max_packet_frames}, "
                        f"{st.pipeline.skeleton.n_joints}, 3) as announced")
            return
        problem = limits.clock_problem(timestamp) or (
            seq > st.next_seq and limits.jump_problem(seq, st.next_seq, st.fps,
                                                      self.config.max_seq_jump))
        if problem:
            st.dropped += n
            self._error(st.stream, "seq" if seq > st.next_seq else "field", problem)
            return
        if self.joined and st.frames_in == 0 and (st.stream, st.gen) in self.joined:
            self.joined.discard((st.stream, st.gen))
            st.next_seq = seq
            st.pipeline.start_at(seq)
        if st.t0 is None:
            st.t0 = timestamp - seq / st.fps
        if seq != st.next_seq:
            if seq > st.next_seq:
                self._flush(st)  # the segmenter learns contiguous runs
                st.lost += seq - st.next_seq
                self.errors.add(st.stream, "gap", f"frames {st.next_seq}..{seq - 1} missing")
                if st.gap_limit.allow(now):  # the rest are counted in the `gap` error
                    filled = seq - st.next_seq <= st.pipeline.fill_frames
                    self._publish(st, protocol.Gap(st.stream, st.next_seq, seq, filled))
            else:
                overlap = st.next_seq - seq
                st.dropped += min(overlap, n)
                self._error(st.stream, "duplicate", f"packet at frame {seq} repeats frames "
                            f"already received (next expected {st.next_seq})", min(overlap, n))
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

    def _report_gaps(self, st: StreamState, bad: int) -> None:
        """Frames skipped without positions (``nan``), and a ``gap`` event (not filled) for
        each gap of frames that came without the features' joints, longer than the gap
        filler fills (docs/guide/formats.md, Gaps)."""
        if bad:
            st.dropped += bad
            self._error(st.stream, "nan", "frames without the joint positions the features "
                        "use, in gaps too long to fill: skipped", bad)
        for start, end in st.pipeline.gaps:
            if st.gap_limit.allow(time.monotonic()):
                self._publish(st, protocol.Gap(st.stream, start, end, False))
        st.pipeline.gaps.clear()

    def _flush(self, st: StreamState) -> None:
        if not st.pending:
            return
        arrays, arrivals = st.pending, st.arrivals
        st.pending, st.arrivals = [], []
        pos = arrays[0] if len(arrays) == 1 else np.concatenate(arrays)
        first = st.next_seq - pos.shape[0]
        try:
            cuts, reps, bad = st.pipeline.push(pos, first)
        except Exception as err:  # never die on input: report and drop these frames
            st.dropped += pos.shape[0]
            self._error(st.stream, "pipeline", f"{pos.shape[0]} frames from {first} not "
                        f"processed: {type(err).__name__}: {err}", pos.shape[0])
            return
        self._report_notices(st)
        self._report_gaps(st, bad)
        self._publish_results(st, cuts, reps)
        self.latency.add(time.perf_counter() - np.array(arrivals))
        if self.config.relabel_interval > 0 and st.pipeline.relabel_due(st.next_relabel):
            self.due[st] = None  # snapshot taken when the worker has a free slot (_feed)


def _same_take(st: StreamState, msg: protocol.Announce) -> bool:
    """Whether ``msg`` announces the open take ``st`` again (rate and skeleton alike)."""
    sk = st.pipeline.skeleton
    return (msg.fps == st.fps and tuple(msg.joints) == tuple(sk.names)
            and list(msg.parents) == [int(p) for p in sk.parents])
