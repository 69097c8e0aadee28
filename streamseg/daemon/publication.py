"""The daemon's way out: events numbered, logged, then published on its PUB socket.

:class:`Publication` owns the event log (optional), the numbering of events per stream id,
the order of a stream id's takes (:class:`~streamseg.daemon.take_order.TakeOrder`) and the
PUB socket. With a log an event is published only once the log's writer thread has committed
it (a subscriber never sees an event that ``since`` cannot give back); the writer says so
through a pipe the daemon's loop polls.
"""

from __future__ import annotations

import collections
import logging
import os

import msgpack
import numpy as np
import zmq

from streamseg import protocol
from streamseg.daemon.eventlog import Numbering, open_log
from streamseg.daemon.security import ipv6
from streamseg.daemon.take_order import TakeOrder

log = logging.getLogger("streamseg.daemon")


class Publication:
    """Number, log and publish events; hold a take's events behind an older take's close.

    Parameters
    ----------
    config : DaemonConfig
        ``state_dir`` (no log when empty or ``"none"``), the log's retention, ``hwm``.
    totals : collections.Counter
        The daemon's totals: ``events`` counts the events sent.
    """

    def __init__(self, config, totals: collections.Counter):
        self.config = config
        self.totals = totals
        # the log's writer thread says "committed" through a pipe the loop polls
        self.wake_fd, self._tx = os.pipe()
        os.set_blocking(self.wake_fd, False)
        os.set_blocking(self._tx, False)
        self.eventlog = open_log(config, notify=self._committed)
        self.numbering = Numbering(self.eventlog)
        self.order = TakeOrder()  # a stream id's events across its takes
        self.pub = None  # made at bind

    def bind(self, ctx: zmq.Context, endpoint: str, secure) -> str:
        """Make and bind the PUB socket (``secure`` applies CURVE); returns its endpoint."""
        self.pub = ctx.socket(zmq.PUB)
        secure(self.pub)
        self.pub.setsockopt(zmq.SNDHWM, self.config.hwm)
        ipv6(self.pub, endpoint)
        self.pub.setsockopt(zmq.LINGER, 2000)  # final events get out at shutdown
        self.pub.bind(endpoint)
        return self.pub.getsockopt_string(zmq.LAST_ENDPOINT)

    def publish(self, st, ev):
        """Number, log and publish one event of ``st`` (None: daemon-wide); returns it with
        its ``seq`` (unnumbered while it waits for an older take of its id to close). With a
        log it goes out once committed (:meth:`publish_logged`)."""
        if self.order and self.order.hold(st, ev):
            return ev
        return self.send(st, ev)

    def send(self, st, ev):
        """:meth:`publish` without the wait for older takes."""
        ev, parts = self.numbering.encode(ev)
        if self.eventlog is None:
            self.pub.send_multipart(parts)
        elif ev.type == "stats":  # behind the events numbered before it
            self.eventlog.publish_after(parts)
            self.publish_logged()
        self.totals["events"] += 1
        if st is not None:
            st.events_out += 1
        return ev

    def skip_unlogged(self, stream: str) -> None:
        """After a restart that resumed ``stream``: the numbers of events published in the
        last moments before the crash may not have reached the log. They are skipped, never
        reused for other events (published only once logged, they are there unless the disk
        refused them); ``since`` says they were skipped, not lost."""
        last = self.numbering.current(stream)
        self.numbering.last[stream] = last + protocol.SEQ_SKIP
        if self.eventlog is not None:
            self.eventlog.skip(stream, last + 1, last + protocol.SEQ_SKIP)

    def close_lost_takes(self, resumed) -> None:
        """``closed`` (reason ``restart``) for the takes a crash ended: events of them are in
        the log, no ``closed``, and they are not in ``resumed``; so every take of an id ends
        with ``closed`` before the next one begins."""
        if self.eventlog is None:
            return
        try:
            lost = [s for s in self.eventlog.open_takes() if s not in resumed]
        except Exception as err:  # an unreadable log is reported by its read counter
            log.warning("event log: the open takes could not be read: %s", err)
            return
        for stream in lost:
            self.publish(None, protocol.Closed(stream, "restart", 0))
        if lost:
            log.info("%d streams not resumed after the restart: closed (restart)", len(lost))

    def since(self, stream: str, seq: int, limit: int) -> dict | None:
        """The control op ``since``: at most ``limit`` logged events of ``stream`` after
        ``seq`` (None without a log); raises LogReadError on a damaged file."""
        if self.eventlog is None:
            return None
        bodies, first = self.eventlog.since(stream, seq, limit)
        last = self.eventlog.logged_seq(stream)
        skipped = self.eventlog.skipped(stream, seq)
        events = [msgpack.unpackb(b, raw=False) for b in bodies]
        return {
            "stream": stream,
            "events": events,
            "first": first,
            "last": last,
            "skipped": skipped,
            "more": len(events) == limit,
        }

    def wait_stats(self) -> dict:
        """Commit-then-publish: each event's wait for its commit, last 4096 events, in ms."""
        if self.eventlog is None or not self.eventlog.waits:
            return {}
        w50, w99 = np.percentile(np.fromiter(self.eventlog.waits, float), (50, 99))
        return {
            "publish_wait_p50_ms": round(w50 * 1e3, 3),
            "publish_wait_p99_ms": round(w99 * 1e3, 3),
        }

    def hello(self, token: str) -> None:
        """The control token's proof on PUB (protocol/auth.py), not numbered."""
        self.pub.send_multipart(protocol.encode(protocol.Hello(token)))

    def _committed(self) -> None:
        """The log's writer thread: a batch is committed (wakes the loop)."""
        try:
            os.write(self._tx, b"\0")
        except (BlockingIOError, OSError):
            pass  # the pipe is full (the loop wakes anyway) or closed (shutdown)

    def woken(self) -> None:
        """The loop saw :attr:`wake_fd` readable: empty the pipe."""
        try:
            while os.read(self.wake_fd, 4096):
                pass
        except (BlockingIOError, OSError):
            pass

    def publish_logged(self) -> None:
        """Publish the events the log has committed, in their order."""
        if self.eventlog is not None:
            for parts in self.eventlog.committed():
                self.pub.send_multipart(parts)

    def publish_final(self, timeout: float) -> None:
        """At shutdown: the final events go out once committed, before the socket closes."""
        if not self.eventlog.sync(timeout):
            log.error(
                "event log %s: the last events were not committed in time: not published",
                self.eventlog.path,
            )
        self.publish_logged()

    def close_log(self) -> None:
        self.eventlog.close()
        self.eventlog.notify = None

    def close_pipe(self) -> None:
        for fd in (self.wake_fd, self._tx):
            os.close(fd)
