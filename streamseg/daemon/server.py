"""The daemon: its parts wired together, and the main loop.

The parts, each in its own module: :class:`~streamseg.daemon.ingest.Ingest` (the ingest
sockets, a receiver thread, a queue bounded in bytes), :class:`~streamseg.daemon.intake.Intake`
(the stream table and the handling of each packet),
:class:`~streamseg.daemon.publication.Publication` (numbering, the event log, the PUB socket
and the order of a stream id's takes), :class:`~streamseg.daemon.relabel_queue.RelabelQueue`
(which stream is relabelled next), :class:`~streamseg.daemon.checkpoint.CheckpointRounds`
(when stream states are copied), :class:`~streamseg.daemon.closed_streams.ClosedStreams`
(what late joiners learn of ended streams), :class:`~streamseg.daemon.storage_report.StorageReport`
(failed writes said as errors), :class:`~streamseg.daemon.control.Control` (the REP socket)
and :class:`~streamseg.daemon.shutdown.Shutdown`. One thread, the loop, runs them all except
the receiver, the event log's writer and the relabel worker: it takes what the receiver
queued (in slices of at most ``intake.SLICE_S``, so control requests and heartbeats are
served between them), publishes events, answers control requests, and hands relabel
snapshots to :class:`~streamseg.daemon.worker.RelabelWorker`, whose results it publishes.
"""

from __future__ import annotations

import collections
import logging
import sys
import threading
import time

import zmq

from streamseg import protocol
from streamseg.config import DaemonConfig
from streamseg.daemon import checkpoint, checkpoint_store, limits
from streamseg.daemon.algorithms import algorithms_for
from streamseg.daemon.allocation import fix_mmap_threshold
from streamseg.daemon.backends import relabel_worker
from streamseg.daemon.closed_streams import ClosedStreams
from streamseg.daemon.control import Control
from streamseg.daemon.cut_events import publish_cut
from streamseg.daemon.eventlog import LogReadError
from streamseg.daemon.ingest import Ingest
from streamseg.daemon.intake import Intake
from streamseg.daemon.options import skeleton_from
from streamseg.daemon.publication import Publication
from streamseg.daemon.relabel_queue import RelabelQueue
from streamseg.daemon.security import (
    ConnectionIds,
    ServerSecurity,
    check_binds,
    control_token,
    ipv6,
)
from streamseg.daemon.shutdown import Shutdown
from streamseg.daemon.state_lock import lock_state_dir, unlock
from streamseg.daemon.storage_report import StorageReport
from streamseg.daemon.streams import Closing, ErrorBook, StreamState

log = logging.getLogger("streamseg.daemon")
SWITCH_INTERVAL = 0.0005  # s: CPython's GIL switch interval while a daemon runs


def _bindable(endpoint: str) -> str:
    # port 0 means "any free port", which ZeroMQ spells "*"
    return (
        endpoint[:-2] + ":*"
        if endpoint.startswith("tcp://") and endpoint.endswith(":0")
        else endpoint
    )


class Daemon:
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

    def __init__(self, config: DaemonConfig | None = None, algorithms=None):
        self.config = config or DaemonConfig()
        self.algorithms = algorithms_for(self.config, algorithms)
        self.ctx = zmq.Context()
        self.closing: dict = {}  # (stream, gen) -> Closing: ended takes awaiting a final relabel
        self.gone = ClosedStreams()  # for late joiners, and the heartbeats' last numbers
        self.errors = ErrorBook()
        self.totals = collections.Counter()
        self.endpoints: dict = {}
        self.ready = threading.Event()
        self._stop = threading.Event()
        self._started = time.monotonic()
        self._next_beat = 0.0
        self._next_sweep = 0.0
        state_dir = self.config.state_dir if self.config.state_dir != "none" else ""
        # before the log and the checkpoints are opened: a second daemon touches neither
        self.state_lock = lock_state_dir(state_dir) if state_dir else None
        self.out = Publication(self.config, self.totals)
        self.eventlog, self.numbering, self.order = (
            self.out.eventlog,
            self.out.numbering,
            self.out.order,
        )
        self.stray = limits.RateLimit(self.config.stray_errors_per_s)
        self.security = None
        self.conn_ids = None  # names of ingest connections without CURVE (security.py)
        self.token = self.token_file = None  # the control token without CURVE (protocol/auth.py)
        self.checkpoints = checkpoint_store.open_store(self.config)
        self.rounds = (
            checkpoint.CheckpointRounds(
                self.checkpoints, self.config.checkpoint_interval, self._checkpoint_copy
            )
            if self.checkpoints is not None
            else None
        )
        self.storage = StorageReport(self.eventlog, self.checkpoints, self.error)
        self.worker = relabel_worker(self.algorithms, self.config)
        self.relabels = RelabelQueue(
            self.worker, self.config.relabel_interval, self.config.final_relabel_bytes
        )
        self.default_skeleton = None
        if self.config.default_skeleton:
            from streamseg.io.asf import read_asf

            asf = read_asf(self.config.default_skeleton)
            self.default_skeleton = skeleton_from(asf.names, asf.parents, up=self.config.default_up)
        self.ingest = None  # its sockets are made at bind
        self.intake = Intake(
            self.config,
            self.algorithms,
            None,
            self,
            self.errors,
            self.numbering,
            self.default_skeleton,
        )
        self.control = None
        self.shutdown = Shutdown(
            self,
            self.worker,
            self.algorithms,
            self.config.shutdown_relabel,
            bool(self.config.heartbeat),
        )

    @property
    def streams(self) -> dict[str, StreamState]:
        """The open streams by id."""
        return self.intake.streams

    @property
    def n_frames(self) -> int:
        """Frames taken since the start."""
        return self.intake.n_frames

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

        self.ingest = self.intake.ingest = Ingest(self.ctx, c, secure_ingest)
        self.intake.owners(self.security is not None, self.token)
        ingest_endpoint = self.ingest.bind(_bindable(c.ingest))
        publish_endpoint = self.out.bind(self.ctx, _bindable(c.publish), secure)
        self.pub = self.out.pub
        self.poller = zmq.Poller()
        self.poller.register(self.ingest.wake, zmq.POLLIN)
        if self.eventlog is not None:
            self.poller.register(self.out.wake_fd, zmq.POLLIN)
        self.endpoints = {"ingest": ingest_endpoint, "publish": publish_endpoint}
        if c.control:
            sock = self.ctx.socket(zmq.REP)
            secure(sock)
            sock.setsockopt(zmq.LINGER, 0)
            ipv6(sock, c.control)
            sock.bind(_bindable(c.control))
            self.control = Control(
                sock, self, self.security is not None, self.token, self.token_file
            )
            self.poller.register(sock, zmq.POLLIN)
            self.endpoints["control"] = sock.getsockopt_string(zmq.LAST_ENDPOINT)
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
        fix_mmap_threshold()  # packets' memory goes back to the system when freed
        try:
            # the control socket answers only once this is done: say why a first start waits
            log.info(
                "warming the kernels (compiled on the first start after an install: a "
                "minute or more; cached after that)"
            )
            spent = self.algorithms.warmup(relabel=self.config.relabel_interval > 0)
            if self.config.relabel_interval > 0:
                self.worker.warm()
            log.info(
                "kernels warmed in %.2f s; ingest %s publish %s control %s",
                spent,
                self.endpoints["ingest"],
                self.endpoints["publish"],
                self.endpoints.get("control", "off"),
            )
            self.worker.start()
            self.ingest.start()
            self._started = time.monotonic()
            if self.eventlog is not None and self.eventlog.quarantined:
                aside, why = self.eventlog.quarantined
                self.error(
                    None,
                    "event_log",
                    f"the event log {self.eventlog.path} was "
                    f"damaged ({why}): moved to {aside}; a new log started",
                )
            self._restore(self._started)
            self.out.close_lost_takes(self.streams)
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
                timeout = (
                    0
                    if self.ingest.items
                    else (
                        1
                        if self.rounds is not None and self.rounds.in_round
                        else 10
                        if busy
                        else 100
                    )
                )
                events = dict(self.poller.poll(self.intake.wait_ms(timeout)))
                now = time.monotonic()
                if self.ingest.wake in events:
                    self.ingest.clear_wake()
                self.intake.take(now)
                if self.control is not None and self.control.sock in events:
                    self.control.serve()
                self.collect()
                if self.eventlog is not None:
                    if self.out.wake_fd in events:
                        self.out.woken()
                    self.out.publish_logged()
                self.feed()
                if now >= self._next_sweep:
                    self._sweep(now)
                if self.config.heartbeat and now >= self._next_beat:
                    self._beat(now)
                if self.rounds is not None and self.rounds.due(now):
                    self.rounds.step(
                        now, self.streams, self.eventlog.failed if self.eventlog is not None else 0
                    )
        finally:
            self._shutdown()
        return 0

    # --- streams -----------------------------------------------------------------------------

    def _restore(self, now: float) -> int:
        """Open the checkpointed streams again (before the loop runs); returns how many."""
        if self.checkpoints is None:
            return 0
        n = 0
        for st in checkpoint.restored(self.checkpoints, self.algorithms):
            self.intake.restored(st, now)
            self.rounds.seen[st.stream] = st.frames_in
            self.out.skip_unlogged(st.stream)
            n += 1
            log.info("stream %s restored from its checkpoint at frame %d", st.stream, st.next_seq)
        self.totals["streams_restored"] += n
        return n

    def _checkpoint_copy(self, st: StreamState):
        """``(stream, frame, snapshot)`` of one stream for a checkpoint, or None."""
        if self.order and self.order.waits(st.stream, st.gen):
            # a take waiting for an older one's `closed`: not resumed after a crash either, so
            # nothing of it can come out before that `closed`
            return None
        self.intake.flush(st)
        try:
            return (st.stream, st.next_seq, checkpoint.snapshot(st))
        except Exception as err:  # e.g. a custom algorithm with state we cannot copy
            self.error(
                st.stream,
                "checkpoint",
                f"stream state not checkpointed: {type(err).__name__}: {err}",
            )
            return None

    # --- events ------------------------------------------------------------------------------

    def publish(self, st: StreamState | None, ev):
        """Number, log and publish one event (:meth:`Publication.publish`)."""
        return self.out.publish(st, ev)

    def results(self, st: StreamState, cuts, reps) -> None:
        """Publish a pipeline step's ``(frame, score, emitted, kind)`` cuts and ``(start, end,
        count, emitted, label, set, duration_s, rom_deg, rom_joint, likeness)`` repetitions
        (live, and the final ones at close)."""
        for frame, score, emitted, kind in cuts:
            publish_cut(self.publish, st, frame, score, emitted, kind)
        for a, b, count, emitted, label, index, *measures in reps:
            st.reps = count
            self.publish(
                st,
                protocol.Rep(
                    st.stream, a, b, count, st.time_of(b), emitted, label, index, *measures
                ),
            )

    def error(self, stream, reason: str, message: str, n: int = 1) -> None:
        st = self.streams.get(stream) if stream else None
        if (
            st is None
            and stream
            and (stream, reason) not in self.errors.counts
            and not self.stray.allow(time.monotonic())
        ):
            stream = None  # a flood of unknown ids: pooled, summarised each heartbeat
        ev = self.errors.add(stream, reason, message, n)
        if ev is not None:
            self.publish(st, ev)

    def notices(self, st: StreamState) -> None:
        """Publish the pipeline's notices (problems that do not stop the stream) as errors."""
        for kind, message in st.pipeline.notices:
            self.error(st.stream, kind, message)
        st.pipeline.notices.clear()

    def opened(self, st: StreamState) -> None:
        self.totals["streams_opened"] += 1
        if self.closing:  # its events wait for older takes' `closed`
            older = sorted(g for (s, g) in self.closing if s == st.stream)
            self.order.opened(st, [(g, self.closing[(st.stream, g)].st) for g in older])
            for g in older:  # this take's events wait for theirs: their final relabels first
                self.relabels.hurry((st.stream, g))

    def flushed(self, st: StreamState) -> None:
        self.relabels.check(st)  # its snapshot is taken when the worker has a free slot

    def close(self, st: StreamState, reason: str) -> None:
        """Final cuts now; the final relabel in the worker; then ``closed``."""
        self.intake.flush(st)
        self.relabels.drop(st)
        try:
            final = st.pipeline.finish()
        except Exception as err:  # never die: report, close without the final cuts
            final = []
            self.error(st.stream, "pipeline", f"final cuts lost: {type(err).__name__}: {err}")
        self.intake.report_gaps(st, st.pipeline.final_bad)  # frames the gap filler held till now
        try:
            final_reps = st.pipeline.finish_reps()
        except Exception as err:  # the counter is optional: report, close without them
            final_reps = []
            self.error(st.stream, "rep", f"final repetitions lost: {type(err).__name__}: {err}")
        self.notices(st)
        self.results(st, final, final_reps)
        job = self.relabels.final_job(st) if self.config.relabel_interval > 0 else None
        if job is not None and not self.relabels.room_for(job):
            job = None  # takes end faster than the worker relabels: memory stays bounded
            self.error(
                st.stream,
                "relabel",
                f"final relabel skipped: {len(self.relabels.finals)} ended takes already wait "
                f"for theirs with {self.relabels.final_bytes / 2**20:.0f} MiB of history "
                f"(final_relabel_bytes; the relabel worker is behind); the live cuts stand",
            )
        self.intake.remove(st)
        st.pipeline.release()  # what only new frames need (the job holds the history)
        if self.checkpoints is not None:  # the take is over: nothing to resume, even if the
            self.checkpoints.forget(st.stream)  # daemon dies before its final relabel
            self.rounds.forget(st.stream)
        if job is None:
            self.closed(st, reason)
        else:
            self.closing[job.key] = Closing(st, reason, job)
            self.relabels.wait_final(job)

    def closed(self, st: StreamState, reason: str) -> None:
        # cuts no final relabel settled (none ran: too few frames, or shutdown's time ran
        # out) stand; after the final relabel there are none left
        for frame, score, emitted, kind, at in st.pipeline.relabelled(None, True, st.next_seq):
            publish_cut(self.publish, st, frame, score, emitted, kind, at, st.revision)
        for ev in self.errors.due_for(st.stream):  # final counts, so `closed` stays last
            self.publish(st, ev)
        self.publish(st, protocol.Closed(st.stream, reason, st.next_seq))
        if self.order:
            self.order.closed(
                st,
                self.out.send,
                lambda: self.numbering.current(st.stream),
                any(s == st.stream for (s, _) in self.closing),
            )
        self.gone.add(st.stream, st.state(), reason)
        log.info("stream %s closed (%s) after %d frames", st.stream, reason, st.next_seq)

    def feed(self) -> None:
        self.relabels.feed(self.streams)

    def unqueue(self, key):
        return self.relabels.take_waiting(key)

    def collect(self) -> None:
        for stream, reason, message in self.worker.notices():  # e.g. the cluster was lost
            self.error(stream if stream in self.streams else None, reason, message)
        for job, result in self.worker.results():
            self.relabelled(job, result)

    def relabelled(self, job, result) -> None:
        stream, gen = job.key
        st = self.streams.get(stream)
        reason = None
        if st is None or st.gen != gen:
            st, reason, _ = self.closing.get(job.key, (None, None, None))
            if st is None:
                return  # the stream was re-announced since; the result is stale
        failed = isinstance(result, Exception)
        if failed:
            self.error(stream, "relabel", f"relabel failed: {type(result).__name__}: {result}")
        settled = st.pipeline.relabelled(
            None if failed else result, job.final, st.next_seq, getattr(job, "focused", False)
        )
        if not failed:
            st.revision += 1
            st.relabel_time = result.elapsed
            ev = protocol.Segments(
                stream,
                st.revision,
                result.start,
                result.end,
                result.segments,
                job.final,
                result.elapsed,
            )
            self.totals["relabels"] += 1
            st.segments = self.publish(st, ev)
        for frame, score, emitted, kind, at in settled:  # after the revision that settles
            publish_cut(self.publish, st, frame, score, emitted, kind, at, st.revision)
        if job.final and reason is not None:
            self.closing.pop(job.key, None)
            self.closed(st, reason)
        elif reason is None:
            self.relabels.check(st)  # became due while this one ran: next in line

    def _sweep(self, now: float) -> None:
        self._next_sweep = now + 0.5
        limit = now - self.config.idle_timeout
        for st in [s for s in self.streams.values() if s.last_seen < limit]:
            self.close(st, "idle")
        self.storage.check()

    def _beat(self, now: float) -> None:
        self._next_beat = now + self.config.heartbeat
        for ev in self.errors.due():
            self.publish(self.streams.get(ev.stream) if ev.stream else None, ev)
        # the last numbers published, so a subscriber sees what it lost after a stream's last
        # event it received (events of a take that waits for an older one are not numbered)
        keys = [*self.gone.recent(now), *self.streams, protocol.DAEMON_WIDE]
        last = {k: n for k in keys if (n := self.numbering.last.get(k))}
        self.publish(
            None,
            protocol.Stats(
                round(now - self._started, 3),
                self._totals(),
                {s: st.stats() for s, st in self.streams.items()},
                last,
            ),
        )

    def _totals(self) -> dict:
        intake = self.intake
        out = dict(
            self.totals, packets=intake.n_packets, frames=intake.n_frames, steps=intake.n_steps
        )
        p50, p99 = intake.latency.percentiles()
        out.update(
            streams=len(self.streams),
            errors=self.errors.total,
            latency_p50_ms=None if p50 is None else round(p50 * 1e3, 3),
            latency_p99_ms=None if p99 is None else round(p99 * 1e3, 3),
            relabel_queue=self.worker.queued(),
            errors_by_reason=self.errors.by_reason(),
            **self.ingest.stats(),
        )
        out.update(self.out.wait_stats())
        if self.checkpoints is not None:
            out["checkpoints"] = self.rounds.copied  # stream states copied for the store
            out["checkpoint_interval_s"] = round(self.rounds.gap, 3)
            out["checkpoints_written"] = self.checkpoints.written  # committed, not queued
        return out

    # --- what the control endpoint and the shutdown ask ----------------------------------------

    def listing(self) -> dict:
        # closed ones too (those `state` still answers for, oldest first): a client that
        # joins after a stream ended (the view beside a daemon) can still list it
        closed = self.gone.listing(self.streams)
        return {
            "streams": [
                {"stream": s, "fps": st.fps, "frame": st.next_seq, "revision": st.revision}
                for s, st in self.streams.items()
            ],
            "closed": closed,
        }

    def stream_state(self, stream) -> dict | None:
        st = self.streams.get(stream)
        if st is not None:
            return st.state()
        for (s, _), waiting in self.closing.items():
            if s == stream:
                return {**waiting.st.state(), "closed": waiting.reason}
        return self.gone.get(stream)

    def open_ids(self) -> list:
        return list(self.streams)

    def status(self) -> dict:
        return {
            "uptime": time.monotonic() - self._started,
            "totals": self._totals(),
            "streams": {s: st.stats() for s, st in self.streams.items()},
        }

    def hello(self, token: str) -> None:
        self.out.hello(token)

    def checkpoint_now(self) -> int | None:
        if self.checkpoints is None:
            return None
        self.checkpoints.wait()
        n = self.rounds.all_now(self.streams)
        self.checkpoints.wait()  # the reply says it is on disk
        return n

    def events_since(self, stream: str, seq: int, limit: int) -> dict | None:
        try:
            return self.out.since(stream, seq, limit)
        except LogReadError:  # a damaged file: said as an `error` event too
            self.storage.check()
            raise

    def logged_streams(self, limit: int) -> list | None:
        if self.eventlog is None:
            return None
        try:
            return self.eventlog.streams(limit)
        except LogReadError:  # a damaged file: said as an `error` event too
            self.storage.check()
            raise

    def take_queued(self) -> None:
        self.intake.take_queued()

    def close_all(self, reason: str) -> None:
        for st in list(self.streams.values()):
            self.close(st, reason)

    def beat(self) -> None:
        self._beat(time.monotonic())

    # --- shutdown ----------------------------------------------------------------------------

    def _shutdown(self) -> None:
        """Final events for every stream, then every part released (each step runs even if
        one before it failed)."""
        try:
            if self.endpoints:
                self.shutdown.final_events()
        finally:
            self.shutdown.release(self._release_steps())

    def _release_steps(self) -> list:
        steps = []
        if self.eventlog is not None and getattr(self, "pub", None) is not None:
            steps.append(
                (
                    "publishing the logged events",
                    lambda: self.out.publish_final(self.config.shutdown_relabel + 5.0),
                )
            )
        steps.append(
            (
                "stopping the relabel worker",
                lambda: self.worker.stop(timeout=self.config.shutdown_relabel),
            )
        )
        if self.ingest is not None:
            steps += [
                ("stopping the ingest", self.ingest.stop),
                ("closing the ingest", self.ingest.close),
            ]
        if self.control is not None:
            steps.append(("closing the control socket", self.control.close))
        if getattr(self, "pub", None) is not None:  # default linger: final events get out
            steps.append(("closing the publish socket", self.pub.close))
        for part in (self.security, self.conn_ids):
            if part is not None:
                steps.append((f"stopping {type(part).__name__}", part.stop))
        steps.append(("terminating the ZeroMQ context", self.ctx.term))
        if self.eventlog is not None:  # after the final events: they are logged too
            steps.append(("closing the event log", self.out.close_log))
        steps.append(("closing the log pipe", self.out.close_pipe))
        if self.checkpoints is not None:
            steps.append(("closing the checkpoint store", self.checkpoints.close))
        # last: another daemon may take the directory now
        steps.append(("unlocking the state directory", self._unlock))
        return steps

    def _unlock(self) -> None:
        unlock(self.state_lock)
        self.state_lock = None
