"""The daemon's sockets and main loop.

One thread owns every socket: it drains up to ``drain`` packets from the PULL ingest socket,
groups them per stream, runs each stream's pipeline once on the concatenated frames (the
vectorised path), publishes events on PUB, answers control requests on REP, and hands relabel
snapshots to :class:`~streamseg.daemon.worker.RelabelWorker`, whose results it publishes.
"""

from __future__ import annotations

import collections
import logging
import os
import sys
import threading
import time

import numpy as np
import zmq

from streamseg import protocol
from streamseg.config import DaemonConfig
from streamseg.daemon import checkpoint, checkpoint_store, limits
from streamseg.daemon.backends import relabel_worker
from streamseg.daemon.control import serve_control
from streamseg.daemon.cut_events import publish_cut
from streamseg.daemon.eventlog import Numbering, open_log
from streamseg.daemon.ingest import Ingest
from streamseg.daemon.intake import Intake
from streamseg.daemon.options import skeleton_from
from streamseg.daemon.pipeline import Algorithms
from streamseg.daemon.security import (
    ConnectionIds,
    ServerSecurity,
    check_binds,
    control_token,
    ipv6,
)
from streamseg.daemon.shutdown import shutdown
from streamseg.daemon.state_lock import lock_state_dir
from streamseg.daemon.streams import ErrorBook, LatencyRing, StreamState
from streamseg.daemon.take_order import TakeOrder
from streamseg.daemon.worker import RelabelJob

log = logging.getLogger("streamseg.daemon")
CLOSED_KEPT = 1000  # states of closed streams kept for late joiners
# seconds the heartbeats still carry a closed stream's last event number (a subscriber that
# lost the stream's tail, `closed` included, learns it from any of them); CLOSED_KEPT at most
CLOSED_LAST_SEQ_S = 30.0
SWITCH_INTERVAL = 0.0005  # s: CPython's GIL switch interval while a daemon runs


def _bindable(endpoint: str) -> str:
    # port 0 means "any free port", which ZeroMQ spells "*"
    return endpoint[:-2] + ":*" if endpoint.startswith("tcp://") and endpoint.endswith(":0") \
        else endpoint


class Daemon(Intake):
    """A live segmentation daemon.

    Parameters
    ----------
    config : DaemonConfig
        Endpoints, limits, relabel cadence.
    algorithms : Algorithms, optional
        The per-stream algorithms (default: LOF cuts + ACA relabel with default configs).

    Examples
    --------
    >>> d = Daemon(DaemonConfig(ingest="tcp://127.0.0.1:0", publish="tcp://127.0.0.1:0",
    ...                         control="tcp://127.0.0.1:0"))          # doctest: +SKIP
    >>> endpoints = d.bind(); threading.Thread(target=d.run).start()  # doctest: +SKIP
    """

    def __init__(self, config: DaemonConfig | None = None, algorithms: Algorithms | None = None):
        self.config = config or DaemonConfig()
        self.algorithms = algorithms or Algorithms(repetitions=self.config.repetitions)
        if self.config.label_memory and self.algorithms.memory_config is None:
            from streamseg.config.memory import LabelMemoryConfig

            # the switch turns the memory on with its defaults; Algorithms(memory_config=...)
            # sets other ones (and turns it on by itself)
            self.algorithms.memory_config = LabelMemoryConfig()
        if self.algorithms.gap_fill_s is None:  # Algorithms(gap_fill_s=...) wins over config
            self.algorithms.gap_fill_s = float(self.config.gap_fill)
        if self.algorithms.settle_s is None:  # as gap_fill_s; settling needs relabels
            self.algorithms.settle_s = float(self.config.settle) \
                if self.config.relabel_interval > 0 else 0.0
        if self.algorithms.focus_s is None:
            self.algorithms.focus_s = float(self.config.focus)
        if self.algorithms.markers is None and self.config.markers:  # as gap_fill_s
            from streamseg.skeleton.marker_map import load_marker_map

            self.algorithms.markers = load_marker_map(self.config.markers)
        self.ctx = zmq.Context()
        self.streams: dict[str, StreamState] = {}
        self.closing: dict = {}  # (stream, gen) -> (state, reason) awaiting the final relabel
        self.closed_states: collections.OrderedDict = collections.OrderedDict()
        self.errors = ErrorBook()
        self.latency = LatencyRing()
        self.n_packets = self.n_frames = 0  # plain ints: updated per packet
        self.totals = collections.Counter()
        self.endpoints: dict = {}
        self.ready = threading.Event()
        self._stop = threading.Event()
        self._gen = 0
        self._dirty: dict = {}  # streams with frames received in this drain
        # streams due for a relabel, oldest first: each gets its snapshot when the worker has
        # a free slot, so the interval a stream gets adapts to the cores (round robin)
        self.due: collections.OrderedDict = collections.OrderedDict()
        self._started = time.monotonic()
        self._next_beat = 0.0
        self._next_sweep = 0.0
        state_dir = self.config.state_dir if self.config.state_dir != "none" else ""
        # before the log and the checkpoints are opened: a second daemon touches neither
        self.state_lock = lock_state_dir(state_dir) if state_dir else None
        # the log's writer thread says "committed" through a pipe the loop polls
        self._log_rx, self._log_tx = os.pipe()
        os.set_blocking(self._log_rx, False)
        os.set_blocking(self._log_tx, False)
        self.eventlog = open_log(self.config, notify=self._log_committed)
        self.order = TakeOrder()  # a stream id's events across its takes
        self.joined: set = set()  # (stream, gen) opened by a subscription, no frame yet
        # closed stream -> until when the heartbeats carry its last number, oldest first
        self._closed_since_beat: collections.OrderedDict = collections.OrderedDict()
        self._store_failed: dict = {}  # reason -> failed writes already reported
        self.numbering = Numbering(self.eventlog)
        self.stray = limits.RateLimit(self.config.stray_errors_per_s)
        self.clients = collections.Counter()  # open streams per client (the quota)
        self._sender = None  # topic frame of the message being handled (its identity)
        self.security = None
        self.conn_ids = None  # names of ingest connections without CURVE (security.py)
        self.token = self.token_file = None  # the control token without CURVE (protocol/auth.py)
        self.checkpoints = checkpoint_store.open_store(self.config)
        self.rounds = (checkpoint.CheckpointRounds(self.checkpoints,
                                                   self.config.checkpoint_interval,
                                                   self._checkpoint_copy)
                       if self.checkpoints is not None else None)
        self.worker = relabel_worker(self.algorithms, self.config)
        self.default_skeleton = None
        if self.config.default_skeleton:
            from streamseg.io.asf import read_asf

            asf = read_asf(self.config.default_skeleton)
            self.default_skeleton = skeleton_from(asf.names, asf.parents,
                                                  up=self.config.default_up)

    # --- lifecycle ---------------------------------------------------------------------------

    def bind(self) -> dict:
        """Create and bind the sockets; returns the bound endpoints (ports resolved)."""
        c = self.config
        check_binds(c)
        if c.curve_dir:
            self.security = ServerSecurity(self.ctx, c.curve_dir)
        else:  # no keys: each ingest connection gets a name of its own (quota, stream owner)
            self.conn_ids = ConnectionIds(self.ctx)
            if c.control:
                self.token, self.token_file = control_token()
        secure = self.security.apply if self.security is not None else (lambda sock: None)
        def secure_ingest(sock):
            secure(sock)
            if self.conn_ids is not None:
                self.conn_ids.apply(sock)

        self.ingest = Ingest(self.ctx, c, secure_ingest)
        ingest_endpoint = self.ingest.bind(_bindable(c.ingest))
        self.pub = self.ctx.socket(zmq.PUB)
        secure(self.pub)
        self.pub.setsockopt(zmq.SNDHWM, c.hwm)
        ipv6(self.pub, c.publish)
        self.pub.setsockopt(zmq.LINGER, 2000)  # final events get out at shutdown
        self.pub.bind(_bindable(c.publish))
        self.control = None
        self.poller = zmq.Poller()
        self.poller.register(self.ingest.wake, zmq.POLLIN)
        if self.eventlog is not None:
            self.poller.register(self._log_rx, zmq.POLLIN)
        self.endpoints = {
            "ingest": ingest_endpoint,
            "publish": self.pub.getsockopt_string(zmq.LAST_ENDPOINT),
        }
        if c.control:
            self.control = self.ctx.socket(zmq.REP)
            secure(self.control)
            self.control.setsockopt(zmq.LINGER, 0)
            ipv6(self.control, c.control)
            self.control.bind(_bindable(c.control))
            self.poller.register(self.control, zmq.POLLIN)
            self.endpoints["control"] = self.control.getsockopt_string(zmq.LAST_ENDPOINT)
        return self.endpoints

    def stop(self) -> None:
        """Ask the loop to finish (thread- and signal-safe); :meth:`run` then shuts down."""
        self._stop.set()

    def run(self) -> int:
        """Warm the kernels, serve until :meth:`stop`, shut down cleanly; returns 0."""
        if not self.endpoints:
            self.bind()
        # the loop and the receiver wait for the GIL behind any thread that holds it (a
        # relabel's Python, a custom algorithm): ZeroMQ queues only ingest_hwm packets per
        # connection meanwhile, so each wait is a hand-over of a few packets. A shorter
        # switch interval than CPython's 5 ms keeps ingest flowing while such a thread runs
        # (docs/decisions.md, Ingest memory)
        sys.setswitchinterval(min(sys.getswitchinterval(), SWITCH_INTERVAL))
        try:
            # the control socket answers only once this is done: say why a first start waits
            log.info("warming the kernels (compiled on the first start after an install: a "
                     "minute or more; cached after that)")
            spent = self.algorithms.warmup(relabel=self.config.relabel_interval > 0)
            if self.config.relabel_interval > 0:
                self.worker.warm()
            log.info("kernels warmed in %.2f s; ingest %s publish %s control %s", spent,
                     self.endpoints["ingest"], self.endpoints["publish"],
                     self.endpoints.get("control", "off"))
            self.worker.start()
            self.ingest.start()
            self._started = time.monotonic()
            if self.eventlog is not None and self.eventlog.quarantined:
                aside, why = self.eventlog.quarantined
                self._error(None, "event_log", f"the event log {self.eventlog.path} was "
                            f"damaged ({why}): moved to {aside}; a new log started")
            checkpoint.restore(self, self._started)
            self._restored_owners()
            self._close_lost_takes()
            if self.eventlog is not None:
                # what the start decided (a damaged log's error, the takes a crash ended, the
                # numbers skipped) is on record before the daemon answers: a `since` right
                # after the first ping finds it
                self.eventlog.sync()
            if self.rounds is not None:
                self.rounds.begin(self._started)
            self.ready.set()
            while not self._stop.is_set():
                busy = self.worker.busy_key is not None or self.worker.queued()
                timeout = 0 if self.ingest.items else \
                    (1 if self.rounds is not None and self.rounds.in_round else
                     10 if busy else 100)
                events = dict(self.poller.poll(timeout))
                now = time.monotonic()
                if self.ingest.wake in events:
                    self.ingest.clear_wake()
                self._take(now)
                if self.control is not None and self.control in events:
                    self._serve_control()
                self._collect()
                if self.eventlog is not None:
                    if self._log_rx in events:
                        self._drain_pipe()
                    self._publish_logged()
                self._feed()
                if now >= self._next_sweep:
                    self._sweep(now)
                if self.config.heartbeat and now >= self._next_beat:
                    self._beat(now)
                if self.rounds is not None and self.rounds.due(now):
                    self.rounds.step(now, self.streams, self.eventlog.failed
                                     if self.eventlog is not None else 0)
        finally:
            self._shutdown()
        return 0

    # --- ingest ------------------------------------------------------------------------------

    def _close_lost_takes(self) -> None:
        """``closed`` (reason ``restart``) for the takes a crash ended: events of them are in
        the log, no ``closed``, and no checkpoint resumed them; so every take of an id ends
        with ``closed`` before the next one begins."""
        if self.eventlog is None:
            return
        try:
            lost = [s for s in self.eventlog.open_takes() if s not in self.streams]
        except Exception as err:  # an unreadable log is reported by its read counter
            log.warning("event log: the open takes could not be read: %s", err)
            return
        for stream in lost:
            self._publish(None, protocol.Closed(stream, "restart", 0))
        if lost:
            log.info("%d streams not resumed after the restart: closed (restart)", len(lost))

    def _feed(self) -> None:
        """Hand the oldest due streams' snapshots to the worker while it has free slots."""
        while self.due and self.worker.free() > 0:
            st, _ = self.due.popitem(last=False)
            if (self.streams.get(st.stream) is st
                    and not self.worker.pending((st.stream, st.gen))):
                self._submit(st, final=False)

    def _submit(self, st: StreamState, final: bool) -> bool:
        feats, frames, focused = st.pipeline.relabel_snapshot(
            final or st.pipeline.learned >= st.next_relabel)
        if feats.shape[0] < 2:
            return False
        if not focused:  # a relabel a cut made due leaves the cadence as it was
            st.next_relabel = st.pipeline.learned + int(round(self.config.relabel_interval
                                                              * st.fps))
        self.worker.submit(RelabelJob((st.stream, st.gen), feats, frames, st.fps,
                                      st.pipeline.previous, final, tuple(st.pipeline.cut_frames),
                                      focused))
        return True

    def _checkpoint_copy(self, st: StreamState):
        """``(stream, frame, snapshot)`` of one stream for a checkpoint, or None."""
        if self.order and self.order.waits(st.stream, st.gen):
            # a take waiting for an older one's `closed`: not resumed after a crash either, so
            # nothing of it can come out before that `closed`
            return None
        self._flush(st)
        self._dirty.pop(st, None)
        try:
            return (st.stream, st.next_seq, checkpoint.snapshot(st))
        except Exception as err:  # e.g. a custom algorithm with state we cannot copy
            self._error(st.stream, "checkpoint", f"stream state not checkpointed: "
                        f"{type(err).__name__}: {err}")
            return None

    # --- events ------------------------------------------------------------------------------

    def _publish(self, st: StreamState | None, ev):
        """Number, log and publish one event; returns it with its ``seq`` (None while it waits
        for an older take of its stream id to close). With a log it is published once
        committed (:meth:`_publish_logged`)."""
        if self.order and self.order.hold(st, ev):
            return ev
        return self._send(st, ev)

    def _send(self, st: StreamState | None, ev):
        ev, parts = self.numbering.encode(ev)
        if self.eventlog is None:
            self.pub.send_multipart(parts)
        elif ev.type == "stats":  # behind the events numbered before it
            self.eventlog.publish_after(parts)
            self._publish_logged()
        self.totals["events"] += 1
        if st is not None:
            st.events_out += 1
        return ev

    def _log_committed(self) -> None:
        """The log's writer thread: a batch is committed (wakes the loop)."""
        try:
            os.write(self._log_tx, b"\0")
        except (BlockingIOError, OSError):
            pass  # the pipe is full (the loop wakes anyway) or closed (shutdown)

    def _drain_pipe(self) -> None:
        try:
            while os.read(self._log_rx, 4096):
                pass
        except (BlockingIOError, OSError):
            pass

    def _publish_logged(self) -> None:
        """Publish the events the log has committed, in their order."""
        for parts in self.eventlog.committed():
            self.pub.send_multipart(parts)

    def _publish_results(self, st: StreamState, cuts, reps) -> None:
        """Publish a pipeline step's ``(frame, score, emitted, kind)`` cuts and ``(start, end,
        count, emitted, label, set)`` repetitions (live, and the final ones at close)."""
        for frame, score, emitted, kind in cuts:
            publish_cut(self._publish, st, frame, score, emitted, kind)
        for a, b, count, emitted, label, index in reps:
            st.reps = count
            self._publish(st, protocol.Rep(st.stream, a, b, count, st.time_of(b), emitted,
                                           label, index))

    def _error(self, stream, reason: str, message: str, n: int = 1) -> None:
        st = self.streams.get(stream) if stream else None
        if st is None and stream and (stream, reason) not in self.errors.counts \
                and not self.stray.allow(time.monotonic()):
            stream = None  # a flood of unknown ids: pooled, summarised each heartbeat
        ev = self.errors.add(stream, reason, message, n)
        if ev is not None:
            self._publish(st, ev)

    def _report_notices(self, st: StreamState) -> None:
        """Publish the pipeline's notices (problems that do not stop the stream) as errors."""
        for kind, message in st.pipeline.notices:
            self._error(st.stream, kind, message)
        st.pipeline.notices.clear()

    def _open(self, stream, fps, skeleton, now):
        st = super()._open(stream, fps, skeleton, now)
        if st is not None and self.closing:  # its events wait for older takes' `closed`
            older = sorted(g for (s, g) in self.closing if s == st.stream)
            self.order.opened(st, [(g, self.closing[(st.stream, g)][0]) for g in older])
        return st

    def _close(self, st: StreamState, reason: str) -> None:
        """Final cuts now; the final relabel in the worker; then ``closed``."""
        self._flush(st)
        self._dirty.pop(st, None)
        self.due.pop(st, None)
        try:
            final = st.pipeline.finish()
        except Exception as err:  # never die: report, close without the final cuts
            final = []
            self._error(st.stream, "pipeline", f"final cuts lost: {type(err).__name__}: {err}")
        self._report_gaps(st, st.pipeline.final_bad)  # frames the gap filler held till now
        try:
            final_reps = st.pipeline.finish_reps()
        except Exception as err:  # the counter is optional: report, close without them
            final_reps = []
            self._error(st.stream, "rep", f"final repetitions lost: {type(err).__name__}: {err}")
        self._report_notices(st)
        self._publish_results(st, final, final_reps)
        del self.streams[st.stream]
        if self.checkpoints is not None:  # the take is over: nothing to resume, even if the
            self.checkpoints.forget(st.stream)  # daemon dies before its final relabel
            self.rounds.forget(st.stream)
        if st.client is not None:
            self.clients[st.client] -= 1
            if not self.clients[st.client]:
                del self.clients[st.client]
        if self.config.relabel_interval > 0 and self._submit(st, final=True):
            self.closing[(st.stream, st.gen)] = (st, reason)
        else:
            self._closed(st, reason)

    def _closed(self, st: StreamState, reason: str) -> None:
        # cuts no final relabel settled (none ran: too few frames, or shutdown's time ran
        # out) stand; after the final relabel there are none left
        for frame, score, emitted, kind, at in st.pipeline.relabelled(None, True, st.next_seq):
            publish_cut(self._publish, st, frame, score, emitted, kind, at, st.revision)
        for ev in self.errors.due_for(st.stream):  # final counts, so `closed` stays last
            self._publish(st, ev)
        self._publish(st, protocol.Closed(st.stream, reason, st.next_seq))
        if self.order:
            self.order.closed(st, self._send, lambda: self.numbering.current(st.stream),
                              any(s == st.stream for (s, _) in self.closing))
        self._closed_since_beat[st.stream] = time.monotonic() + CLOSED_LAST_SEQ_S
        self._closed_since_beat.move_to_end(st.stream)
        state = st.state()
        state["closed"] = reason
        self.closed_states[st.stream] = state
        self.closed_states.move_to_end(st.stream)
        while len(self.closed_states) > CLOSED_KEPT:
            self.closed_states.popitem(last=False)
        log.info("stream %s closed (%s) after %d frames", st.stream, reason, st.next_seq)

    def _collect(self) -> None:
        for stream, reason, message in self.worker.notices():  # e.g. the cluster was lost
            self._error(stream if stream in self.streams else None, reason, message)
        for job, result in self.worker.results():
            self._relabelled(job, result)

    def _relabelled(self, job, result) -> None:
        stream, gen = job.key
        st = self.streams.get(stream)
        reason = None
        if st is None or st.gen != gen:
            st, reason = self.closing.get(job.key, (None, None))
            if st is None:
                return  # the stream was re-announced since; the result is stale
        failed = isinstance(result, Exception)
        if failed:
            self._error(stream, "relabel", f"relabel failed: {type(result).__name__}: {result}")
        settled = st.pipeline.relabelled(None if failed else result, job.final, st.next_seq,
                                         getattr(job, "focused", False))
        if not failed:
            st.revision += 1
            st.relabel_time = result.elapsed
            ev = protocol.Segments(stream, st.revision, result.start, result.end,
                                   result.segments, job.final, result.elapsed)
            self.totals["relabels"] += 1
            st.segments = self._publish(st, ev)
        for frame, score, emitted, kind, at in settled:  # after the revision that settles
            publish_cut(self._publish, st, frame, score, emitted, kind, at, st.revision)
        if job.final and reason is not None:
            self.closing.pop(job.key, None)
            self._closed(st, reason)
        elif reason is None and st.pipeline.relabel_due(st.next_relabel):
            self.due[st] = None  # became due while this one ran: next in line

    def _sweep(self, now: float) -> None:
        self._next_sweep = now + 0.5
        limit = now - self.config.idle_timeout
        for st in [s for s in self.streams.values() if s.last_seen < limit]:
            self._close(st, "idle")
        self._report_storage()

    def _report_storage(self) -> None:
        """Failed writes of the state directory (disk full, unwritable), counted by the writer
        threads, as daemon-wide ``error`` events: the live events go on, but an operator must
        learn that the log or the checkpoints are not being kept."""
        for store, reason, what in ((self.eventlog, "event_log", "events not logged"),
                                    (self.checkpoints, "checkpoint", "checkpoint writes failed")):
            n = store.failed - self._store_failed.get(reason, 0) if store is not None else 0
            if n > 0:
                self._store_failed[reason] = store.failed
                self._error(None, reason, f"{what} in {store.path} (disk full or not "
                                          "writable? the daemon's log says): free space there, "
                                          "or restart with another --state-dir", n)
        store = self.checkpoints
        n = store.paused - self._store_failed.get("paused", 0) if store is not None else 0
        if n > 0:
            self._store_failed["paused"] = store.paused
            free = "" if store.free_bytes is None else f" ({store.free_bytes / 1e6:.1f} MB free)"
            self._error(None, "checkpoint", f"checkpoint rounds paused: the disk of "
                        f"{store.path.parent} is (nearly) full{free} and the event log goes "
                        "first; they resume when there is room", n)
        log_ = self.eventlog
        n = log_.read_failed - self._store_failed.get("read", 0) if log_ is not None else 0
        if n > 0:
            self._store_failed["read"] = log_.read_failed
            self._error(None, "event_log", f"the event log {log_.path} could not be read (a "
                        "damaged file? the daemon's log says): `since` cannot answer from it; "
                        "stop the daemon and move the file aside (a new log starts)", n)

    def _beat(self, now: float) -> None:
        self._next_beat = now + self.config.heartbeat
        for ev in self.errors.due():
            self._publish(self.streams.get(ev.stream) if ev.stream else None, ev)
        # the last numbers published, so a subscriber sees what it lost after a stream's last
        # event it received (events of a take that waits for an older one are not numbered)
        gone = self._closed_since_beat
        while gone and (next(iter(gone.values())) < now or len(gone) > CLOSED_KEPT):
            gone.popitem(last=False)
        keys = [*gone, *self.streams, protocol.DAEMON_WIDE]
        last = {k: n for k in keys if (n := self.numbering.last.get(k))}
        self._publish(None, protocol.Stats(round(now - self._started, 3), self._totals(),
                                           {s: st.stats() for s, st in self.streams.items()},
                                           last))

    def _totals(self) -> dict:
        out = dict(self.totals, packets=self.n_packets, frames=self.n_frames)
        p50, p99 = self.latency.percentiles()
        out.update(streams=len(self.streams), errors=self.errors.total,
                   latency_p50_ms=None if p50 is None else round(p50 * 1e3, 3),
                   latency_p99_ms=None if p99 is None else round(p99 * 1e3, 3),
                   relabel_queue=self.worker.queued(), errors_by_reason=self.errors.by_reason(),
                   **self.ingest.stats())
        if self.eventlog is not None and self.eventlog.waits:
            # commit-then-publish: each event's wait for its commit, last 4096 events
            w50, w99 = np.percentile(np.fromiter(self.eventlog.waits, float), (50, 99))
            out.update(publish_wait_p50_ms=round(w50 * 1e3, 3),
                       publish_wait_p99_ms=round(w99 * 1e3, 3))
        if self.checkpoints is not None:
            out["checkpoints"] = self.rounds.copied  # stream states copied for the store
            out["checkpoint_interval_s"] = round(self.rounds.gap, 3)
            out["checkpoints_written"] = self.checkpoints.written  # committed, not queued
        return out

    # --- control ------------------------------------------------------------------------------

    def _serve_control(self) -> None:
        serve_control(self)

    # --- shutdown ----------------------------------------------------------------------------

    def _shutdown(self) -> None:
        shutdown(self)
