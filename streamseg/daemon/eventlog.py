"""The event log: every numbered event, committed to SQLite (WAL) before it is published.

The daemon's loop only appends ``(stream, seq, type, time, body)`` rows and the events'
wire frames to lists (no I/O on the ingest path); :class:`EventLog`'s thread takes them,
writes the rows with one ``executemany`` in one transaction, and only then hands the frames
back (:meth:`EventLog.committed`, the loop is woken by ``notify``) for the loop to publish.
So every event a subscriber has seen is in the log: a crash loses only events nobody saw.
A batch is whatever the loop appended while the previous one was written, and commits come
at most every ``batch_interval`` (5 ms): a lone event waits for one commit, a burst shares
one (the wait is in ``stats``: ``publish_wait_p50_ms``, ``publish_wait_p99_ms``). Retention
(age, then size) runs in the same thread in bounded steps. The log keeps a reserve of free
pages in its own file (and its WAL at its size), so when the disk fills up it still has room
while the checkpoints pause.

A damaged file is found at start (opening fails or ``PRAGMA quick_check`` does not answer
``ok``) and moved aside as ``events.corrupt-<time>.sqlite``; :attr:`EventLog.quarantined`
says so, for the daemon to publish. Read errors later are counted (:attr:`EventLog.read_failed`)
and raised as :class:`LogReadError`, which names the file. The file's schema, batch
transaction and retention step are in :mod:`~streamseg.daemon.eventlog_file`.
"""

from __future__ import annotations

import collections
import logging
import sqlite3
import threading
import time
from pathlib import Path

from streamseg.daemon.eventlog_file import (
    SCHEMA,
    live_size,
    reserve,
    retain_step,
    write_rows,
)

# moved out of this module; server.py still takes them from here
from streamseg.daemon.numbering import Numbering as Numbering
from streamseg.daemon.state_files import LogReadError as LogReadError
from streamseg.daemon.state_files import connect, move_aside

log = logging.getLogger("streamseg.daemon")


def open_log(config, notify=None) -> EventLog | None:
    """The daemon's event log under ``config.state_dir`` (None without a state directory)."""
    if not config.state_dir or config.state_dir == "none":
        return None
    return EventLog(
        config.state_dir,
        max_bytes=int(config.log_max_mb * 1e6),
        max_age=config.log_max_days * 86400.0,
        notify=notify,
    )


class EventLog:
    """Commits events to ``<state_dir>/events.sqlite``, then hands them back for publication,
    and answers ``since`` queries.

    Parameters
    ----------
    state_dir : str or Path
        Directory (created) holding ``events.sqlite``.
    max_bytes : int
        Retention by size: when the live pages exceed this, the oldest events are deleted.
    max_age : float
        Retention by age (seconds): older events are deleted.
    batch_interval : float
        Seconds between the starts of two commits at least (a burst of events shares one).
    retention_interval : float
        Seconds between retention passes.
    notify : callable, optional
        Called by the writer thread after each batch (committed or not): the frames wait in
        :meth:`committed`.
    """

    def __init__(
        self,
        state_dir,
        max_bytes: int = 256 << 20,
        max_age: float = 7 * 86400.0,
        batch_interval: float = 0.005,
        retention_interval: float = 10.0,
        notify=None,
        flush_interval: float | None = None,
    ):
        self.dir = Path(state_dir)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.path = self.dir / "events.sqlite"
        self.max_bytes, self.max_age = max_bytes, max_age
        self.batch_interval = batch_interval if flush_interval is None else flush_interval
        self.retention_interval = retention_interval
        self.notify = notify
        self.quarantined = None  # (the damaged file moved aside, what was wrong)
        try:
            self._open()
        except sqlite3.DatabaseError as err:
            self._close_connections()
            aside = move_aside(self.path, "events")
            self.quarantined = (aside, str(err))
            log.warning(
                "event log %s is damaged (%s): moved to %s; a new log starts (the "
                "old events stay readable only there)",
                self.path,
                err,
                aside,
            )
            self._open()
        self._pending: list = []  # rows appended by the loop thread
        self._out: list = []  # the frames to publish once the rows before them are committed
        self._skips: list = []  # (stream, lo, hi, t) of numbers skipped at a restart
        self._inflight: list = []  # the rows the writer is committing
        self._done: collections.deque = collections.deque()  # frames committed, to publish
        self._swap = threading.Condition()
        self._wake = threading.Event()
        self._stopping = threading.Event()
        self._writing = False
        self.waits: collections.deque = collections.deque(maxlen=4096)  # s, queued->out
        self.written = 0
        self.failed = 0  # events not written (disk full, unwritable): the daemon reports them
        self.read_failed = 0  # reads that failed (a damaged file): the daemon reports them
        self.deleted = 0
        self.batches = 0
        self.write_seconds = 0.0
        self.cpu_seconds = 0.0  # the writer thread's CPU time (batches and retention)
        self.live_bytes = 0  # measured by the last retention pass
        self.retentions = 0
        self._retain_error = None  # the last retention failure (logged once per kind)
        self._next_retention = 0.0
        self._thread = threading.Thread(target=self._run, name="streamseg-eventlog", daemon=True)
        self._thread.start()

    def _open(self) -> None:
        self._w = self._r = None
        self._w = connect(self.path, auto_vacuum=True)
        self._w.executescript(SCHEMA)
        check = self._w.execute("PRAGMA quick_check").fetchall()
        if check != [("ok",)]:
            raise sqlite3.DatabaseError(f"quick_check: {'; '.join(r[0] for r in check[:3])}")
        self._reserve()
        self._r = connect(self.path)  # the loop's reader (control requests)

    def _close_connections(self) -> None:
        for con in (self._w, self._r):
            if con is not None:
                try:
                    con.close()
                except sqlite3.Error:
                    pass

    def _reserve(self) -> None:
        try:
            reserve(self._w)
        except sqlite3.OperationalError as err:  # no room for it: the log goes on without
            log.warning("event log %s: no room for its reserve (%s)", self.path, err)

    # --- the loop's side ---------------------------------------------------------------------

    def append(self, stream: str, seq: int, kind: str, body: bytes, parts=None) -> None:
        """Queue one event (no I/O); ``parts``, its wire frames, come back from
        :meth:`committed` once it is committed. The first event of a batch wakes the writer."""
        with self._swap:
            self._pending.append((stream, seq, kind, time.time(), body))
            if parts is not None:
                self._out.append((time.monotonic(), parts))
            first = len(self._pending) == 1
        if first:
            self._wake.set()

    def publish_after(self, parts) -> None:
        """Queue frames of an unlogged event (``stats``) behind the logged ones before it."""
        with self._swap:
            if not self._pending and not self._writing:
                self._done.append([(None, parts)])
                return
            self._out.append((None, parts))

    def skip(self, stream: str, lo: int, hi: int) -> None:
        """Record that numbers ``lo..hi`` of ``stream`` are never used (a restart after a
        crash): ``since`` tells them from events lost to retention."""
        with self._swap:
            self._skips.append((stream, lo, hi, time.time()))
        self._wake.set()

    def committed(self) -> list:
        """The frames of every event committed since the last call (and of the unlogged ones
        queued between them), in order; the wait of each logged one (queued to now) goes to
        :attr:`waits`."""
        out = []
        now = time.monotonic()
        while self._done:
            for t, parts in self._done.popleft():
                if t is not None:
                    self.waits.append(now - t)
                out.append(parts)
        return out

    def sync(self, timeout: float = 10.0) -> bool:
        """Block until every event (and skipped range) appended so far is committed (or
        failed); False on timeout."""
        deadline = time.monotonic() + timeout
        self._wake.set()
        with self._swap:
            while self._pending or self._skips or self._writing or self._out:
                left = deadline - time.monotonic()
                if left <= 0 or not self._thread.is_alive():
                    return False
                self._swap.wait(left)
        return True

    def last_seq(self, stream: str) -> int:
        """The highest sequence number given to ``stream`` (0: none), committed or not."""
        best = 0
        with self._swap:
            mem = self._inflight + self._pending
        for it in mem:
            if it[0] == stream and it[1] > best:
                best = it[1]
        return max(best, self.logged_seq(stream))

    def logged_seq(self, stream: str) -> int:
        """The highest sequence number of ``stream`` in the file (0: none); raises
        :class:`LogReadError`."""
        return self._read("SELECT max(seq) FROM events WHERE stream = ?", (stream,))[0][0] or 0

    def since(self, stream: str, seq: int, limit: int = 1000) -> tuple[list, int]:
        """``(bodies, first)``: up to ``limit`` committed event bodies of ``stream`` with
        sequence number > ``seq`` in order, and the lowest sequence number still held (0: none
        held). Raises :class:`LogReadError`."""
        rows = self._read(
            "SELECT body FROM events WHERE stream = ? AND seq > ? ORDER BY seq LIMIT ?",
            (stream, seq, limit),
        )
        first = self._read("SELECT min(seq) FROM events WHERE stream = ?", (stream,))[0][0]
        return [r[0] for r in rows], first or 0

    def streams(self, limit: int = 10000) -> list:
        """``[(stream, first, last), ...]``: every stream id the file holds events of, with
        its lowest and highest sequence number, in the order of their oldest event held; at
        most ``limit``. A lookup of the index per id (no scan of the rows): the loop answers
        it between packets. Raises :class:`LogReadError`."""
        out, key = [], None
        while len(out) < limit:
            row = self._read(
                "SELECT min(stream) FROM events"
                if key is None
                else "SELECT min(stream) FROM events WHERE stream > ?",
                () if key is None else (key,),
            )
            key = row[0][0]
            if key is None:
                break
            first_id, first = self._read(
                "SELECT id, seq FROM events WHERE stream = ? ORDER BY seq LIMIT 1", (key,)
            )[0]
            out.append((first_id, key, first, self.logged_seq(key)))
        return [row[1:] for row in sorted(out)]

    def skipped(self, stream: str, seq: int) -> list:
        """``[[lo, hi], ...]``: the ranges of numbers of ``stream`` above ``seq`` skipped at a
        restart (never used by any event)."""
        return [
            list(r)
            for r in self._read(
                "SELECT lo, hi FROM skips WHERE stream = ? AND hi > ? ORDER BY lo", (stream, seq)
            )
        ]

    def _read(self, sql: str, args: tuple) -> list:
        try:
            return self._r.execute(sql, args).fetchall()
        except sqlite3.Error as err:
            self.read_failed += 1
            raise LogReadError(
                f"the event log {self.path} could not be read ({err}): it may "
                "be damaged; stop the daemon and move it aside (a new one "
                "starts then)"
            ) from err

    def open_takes(self) -> list:
        """The stream ids whose last take published events but no ``closed`` (a crash)."""
        return [r[0] for r in self._read("SELECT stream FROM open_takes", ())]

    def backlog(self) -> int:
        return len(self._pending) + len(self._inflight)

    def close(self, timeout: float = 10.0) -> None:
        """Write everything queued, then stop the thread and close the file."""
        self._stopping.set()
        self._wake.set()
        self._thread.join(timeout)
        self._r.close()
        if not self._thread.is_alive():
            self._w.close()

    # --- the writer thread -------------------------------------------------------------------

    def _run(self) -> None:
        self._retain()
        last = 0.0
        while True:
            # until an event is queued; while idle only once per retention interval
            self._wake.wait(self.retention_interval)
            self._wake.clear()
            stopping = self._stopping.is_set()
            wait = last + self.batch_interval - time.monotonic()
            if wait > 0 and not stopping:
                time.sleep(wait)  # commits at most every batch_interval: bursts share one
            with self._swap:
                self._inflight, self._pending = self._pending, []
                out, self._out = self._out, []
                skips, self._skips = self._skips, []
                self._writing = True
            c0 = time.thread_time()
            last = time.monotonic()
            if self._inflight or skips:
                self._write(self._inflight, skips)
            with self._swap:
                self._inflight = []
                self._writing = False
                if out:
                    self._done.append(out)
                self._swap.notify_all()
            if out and self.notify is not None:
                self.notify()
            now = time.monotonic()
            if now >= self._next_retention:
                self._next_retention = now + self.retention_interval
                if self._retain():
                    self._next_retention = now  # more to delete: the next step soon
                    self._wake.set()
            self.cpu_seconds += time.thread_time() - c0
            if stopping and not self._pending and not self._out:
                return

    def _write(self, batch: list, skips: list = ()) -> None:
        t0 = time.perf_counter()
        try:
            write_rows(self._w, batch, skips)
            self.written += len(batch)
        except sqlite3.Error as err:  # a full disk must not stop the daemon: say so, go on
            if not self.failed:
                log.error(
                    "event log %s: %d events not written: %s (counted from now on)",
                    self.path,
                    len(batch),
                    err,
                )
            self.failed += len(batch)
            try:
                self._w.execute("ROLLBACK")
            except sqlite3.Error:
                pass
        self.batches += 1
        self.write_seconds += time.perf_counter() - t0

    def _retain(self) -> bool:
        """One step of retention: delete events older than ``max_age``, then the oldest while
        over ``max_bytes`` (:func:`~streamseg.daemon.eventlog_file.retain_step`); True when more is
        due."""
        try:
            more = retain_step(self._w, self.max_age, self.max_bytes, self._count_deleted)
            self.live_bytes = self.size()
            self.retentions += 1
            self._retain_error = None
            return more
        except sqlite3.Error as err:
            self.read_failed += 1
            if str(err) != self._retain_error:  # once per kind of failure, not every pass
                log.error(
                    "event log %s: retention failed: %s (said once; the daemon's "
                    "`error` events count the failures)",
                    self.path,
                    err,
                )
                self._retain_error = str(err)
            return False

    def _count_deleted(self, n: int) -> None:
        self.deleted += n

    def size(self) -> int:
        """Bytes in use by live pages (the file may be larger until vacuumed)."""
        return live_size(self._w)
