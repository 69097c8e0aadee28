"""The event log: every numbered event, appended to SQLite (WAL) by a writer thread.

The daemon's loop only appends ``(stream, seq, type, time, body)`` tuples to a list (no I/O on
the ingest path); :class:`EventLog`'s thread takes the list every ``flush_interval`` seconds
and writes it with one ``executemany`` in one transaction. Retention (age, then size) runs in
the same thread. :meth:`EventLog.since` answers the control op ``since`` from the database
plus the tuples not yet committed, so nothing published is ever missing from a reply.
"""

from __future__ import annotations

import collections
import dataclasses
import logging
import os
import sqlite3
import threading
import time
from pathlib import Path

from streamseg import protocol

log = logging.getLogger("streamseg.daemon")

SCHEMA = """
CREATE TABLE IF NOT EXISTS events (
    id INTEGER PRIMARY KEY,
    stream TEXT NOT NULL,
    seq INTEGER NOT NULL,
    type TEXT NOT NULL,
    t REAL NOT NULL,
    body BLOB NOT NULL
);
CREATE INDEX IF NOT EXISTS events_stream_seq ON events (stream, seq);
"""


def default_state_dir() -> Path:
    """``$XDG_STATE_HOME/streamseg``, else ``~/.local/state/streamseg``."""
    base = os.environ.get("XDG_STATE_HOME") or os.path.join(os.path.expanduser("~"), ".local",
                                                            "state")
    return Path(base) / "streamseg"


def open_log(config) -> EventLog | None:
    """The daemon's event log under ``config.state_dir`` (None without a state directory)."""
    if not config.state_dir or config.state_dir == "none":
        return None
    return EventLog(config.state_dir, max_bytes=int(config.log_max_mb * 1e6),
                    max_age=config.log_max_days * 86400.0)


def connect(path: Path) -> sqlite3.Connection:
    """A connection in WAL mode (readers never block the writer), autocommit off."""
    con = sqlite3.connect(str(path), timeout=30, check_same_thread=False,
                          isolation_level=None)
    con.execute("PRAGMA journal_mode=WAL")
    # NORMAL in WAL: a commit survives a crash of the process (kill -9); only a power loss
    # can take the last commits, and never corrupts the file
    con.execute("PRAGMA synchronous=NORMAL")
    return con


class EventLog:
    """Appends events to ``<state_dir>/events.sqlite`` and answers ``since`` queries.

    Parameters
    ----------
    state_dir : str or Path
        Directory (created) holding ``events.sqlite``.
    max_bytes : int
        Retention by size: when the live pages exceed this, the oldest events are deleted.
    max_age : float
        Retention by age (seconds): older events are deleted.
    flush_interval : float
        Seconds between the writer's batches.
    """

    def __init__(self, state_dir, max_bytes: int = 256 << 20, max_age: float = 7 * 86400.0,
                 flush_interval: float = 0.05, retention_interval: float = 10.0):
        self.dir = Path(state_dir)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.path = self.dir / "events.sqlite"
        self.max_bytes, self.max_age, self.flush_interval = max_bytes, max_age, flush_interval
        self.retention_interval = retention_interval
        self._w = connect(self.path)
        self._w.execute("PRAGMA auto_vacuum=INCREMENTAL")  # takes effect on a new file only
        self._w.executescript(SCHEMA)
        self._r = connect(self.path)  # the loop's reader (control requests)
        self._pending: list = []  # appended by the loop thread only
        self._inflight: list = []  # the batch the writer is committing
        self._swap = threading.Lock()
        self._wake = threading.Event()
        self._stopping = threading.Event()
        self.written = 0
        self.failed = 0  # events not written (disk full, unwritable): the daemon reports them
        self.deleted = 0
        self.batches = 0
        self.write_seconds = 0.0
        self.cpu_seconds = 0.0  # the writer thread's CPU time (batches and retention)
        self.live_bytes = 0  # measured by the last retention pass
        self.retentions = 0
        self._next_retention = 0.0
        self._thread = threading.Thread(target=self._run, name="streamseg-eventlog", daemon=True)
        self._thread.start()

    # --- the loop's side ---------------------------------------------------------------------

    def append(self, stream: str, seq: int, kind: str, body: bytes) -> None:
        """Queue one event (no I/O). The lock keeps an append from landing in a batch the
        writer has already taken; the first event of a batch wakes the writer."""
        with self._swap:
            self._pending.append((stream, seq, kind, time.time(), body))
            first = len(self._pending) == 1
        if first:
            self._wake.set()

    def last_seq(self, stream: str) -> int:
        """The highest sequence number logged for ``stream`` (0: none)."""
        best = 0
        with self._swap:
            mem = self._inflight + self._pending
        for it in mem:
            if it[0] == stream and it[1] > best:
                best = it[1]
        row = self._r.execute("SELECT max(seq) FROM events WHERE stream = ?", (stream,)).fetchone()
        return max(best, row[0] or 0)

    def since(self, stream: str, seq: int, limit: int = 1000) -> tuple[list, int]:
        """``(bodies, first)``: up to ``limit`` event bodies of ``stream`` with sequence number
        > ``seq`` in order, and the lowest sequence number still held (0: none held).

        The uncommitted tuples are copied *before* the database is read: a tuple leaves memory
        only after its commit, so each event is in one of the two (duplicates are dropped).
        """
        with self._swap:
            mem = [it for it in self._inflight + self._pending if it[0] == stream and it[1] > seq]
        rows = self._r.execute("SELECT seq, body FROM events WHERE stream = ? AND seq > ? "
                               "ORDER BY seq LIMIT ?", (stream, seq, limit)).fetchall()
        got = {s: b for s, b in rows}
        for it in mem:
            got.setdefault(it[1], it[4])
        first = self._r.execute("SELECT min(seq) FROM events WHERE stream = ?",
                                (stream,)).fetchone()[0]
        if first is None:
            first = min(got, default=0)
        return [got[s] for s in sorted(got)[:limit]], first

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
        while True:
            # until an event is queued; while idle only once per retention interval
            self._wake.wait(self.retention_interval)
            self._wake.clear()
            stopping = self._stopping.is_set()
            if not stopping:
                time.sleep(self.flush_interval)  # gather a batch
            with self._swap:
                self._inflight, self._pending = self._pending, []
            c0 = time.thread_time()
            if self._inflight:
                self._write(self._inflight)
            with self._swap:
                self._inflight = []
            now = time.monotonic()
            if now >= self._next_retention:
                self._next_retention = now + self.retention_interval
                self._retain()
            self.cpu_seconds += time.thread_time() - c0
            if stopping and not self._pending:
                return

    def _write(self, batch: list) -> None:
        t0 = time.perf_counter()
        try:
            self._w.execute("BEGIN")
            self._w.executemany("INSERT INTO events (stream, seq, type, t, body) "
                                "VALUES (?, ?, ?, ?, ?)", batch)
            self._w.execute("COMMIT")
            self.written += len(batch)
        except sqlite3.Error as err:  # a full disk must not stop the daemon: say so, go on
            log.error("event log %s: %d events not written: %s", self.path, len(batch), err)
            self.failed += len(batch)
            try:
                self._w.execute("ROLLBACK")
            except sqlite3.Error:
                pass
        self.batches += 1
        self.write_seconds += time.perf_counter() - t0

    def _retain(self) -> None:
        """Delete events older than ``max_age``, then the oldest while over ``max_bytes``."""
        try:
            cur = self._w.execute("DELETE FROM events WHERE t < ?", (time.time() - self.max_age,))
            self.deleted += cur.rowcount
            for _ in range(100):
                if self.size() <= self.max_bytes:
                    break
                n = self._w.execute("SELECT count(*) FROM events").fetchone()[0]
                if n == 0:
                    break
                cut = self._w.execute("SELECT id FROM events ORDER BY id LIMIT 1 OFFSET ?",
                                      (max(n // 10, 1) - 1,)).fetchone()[0]
                cur = self._w.execute("DELETE FROM events WHERE id <= ?", (cut,))
                self.deleted += cur.rowcount
            self._w.execute("PRAGMA incremental_vacuum")
            self.live_bytes = self.size()
            self.retentions += 1
        except sqlite3.Error as err:
            log.error("event log %s: retention failed: %s", self.path, err)

    def size(self) -> int:
        """Bytes in use by live pages (the file may be larger until vacuumed)."""
        pages = self._w.execute("PRAGMA page_count").fetchone()[0]
        free = self._w.execute("PRAGMA freelist_count").fetchone()[0]
        return (pages - free) * self._w.execute("PRAGMA page_size").fetchone()[0]


class Numbering:
    """Gives each published event its stream's next sequence number and logs it.

    Numbers are per stream id (``*`` for daemon-wide events), start at 1 and continue over
    re-announcements and, with an event log, over restarts. ``stats`` heartbeats are not
    numbered (each supersedes the last). Counters of ids without an open stream (e.g.
    ``unknown_stream`` errors) are kept for the last ``MAX_IDS`` ids; with a log an evicted
    counter is read back from it.
    """

    MAX_IDS = 100_000

    def __init__(self, eventlog: EventLog | None):
        self.log = eventlog
        self.last: collections.OrderedDict = collections.OrderedDict()

    def current(self, key: str) -> int:
        """The last number given to ``key`` (0: none yet)."""
        n = self.last.get(key)
        if n is None:
            n = self.log.last_seq(key) if self.log is not None else 0
            if len(self.last) >= self.MAX_IDS:
                self.last.popitem(last=False)
            self.last[key] = n
        else:
            self.last.move_to_end(key)
        return n

    def next(self, key: str) -> int:
        n = self.current(key) + 1
        self.last[key] = n
        return n

    def encode(self, ev):
        """``(numbered event, [topic, body])``; ``stats`` go out unnumbered and unlogged."""
        if ev.type == "stats":
            return ev, protocol.encode(ev)
        key = ev.stream if ev.stream is not None else protocol.DAEMON_WIDE
        n = self.next(key)
        ev = dataclasses.replace(ev, seq=n)
        parts = protocol.encode(ev)
        if self.log is not None:
            self.log.append(key, n, ev.type, parts[1])
        return ev, parts
