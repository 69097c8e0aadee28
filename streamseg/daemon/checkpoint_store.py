"""``<state_dir>/checkpoints.sqlite``: one row per open stream (its state, packed by
:mod:`streamseg.daemon.state_codec`) and the stream's array chunks, written by a thread.

A round inserts only the chunks the store does not hold yet for the stream and deletes, in
the same transaction, those its new state no longer uses; a stream forgotten loses its row
and its chunks together.
"""

from __future__ import annotations

import collections
import logging
import os
import shutil
import sqlite3
import threading
import time

import msgpack

from streamseg.daemon.state_codec import load, packable, stored
from streamseg.daemon.state_files import connect
from streamseg.state import StateVersionError
from streamseg.state_migrations import FORMAT, READS

log = logging.getLogger("streamseg.daemon")

PACE = 1.0
# Packing a stream holds the GIL (0.2-0.3 ms, benchmarks/daemon_faults.py) and a round packs
# the streams back to back; the loop, wanting the GIL back after each socket call, then waits
# up to the interpreter's switch interval (5 ms). A pause after each array hands it over (0:
# no pause). 0d6c5cf:benchmarks/checkpoint_pause.py, 250 streams on a 2-core VM at its
# capacity knee, medians of 4 interleaved runs (2026-12-02): packet p50 1.94 ms without
# durability, 4.96 ms with the pause, 8.86 ms without it; durability CPU 2.6 % against 4.4 %
# (runs scatter widely).
BREATHE = 0.0001  # seconds


def _breathe() -> None:
    time.sleep(BREATHE)


NICE = 10  # the writer thread runs this many nice levels below the daemon (at most 19)
# The event log has priority over the checkpoints on the state directory's disk: a round is
# not written (paused) unless the disk keeps this much free after it (twice its bytes: the
# WAL, then the file), so the log never meets a disk the checkpoints filled; and the WAL is
# truncated after each round, so the checkpoints hold no more than their file
LOW_WATER = 16 << 20  # bytes

SCHEMA = """
CREATE TABLE IF NOT EXISTS checkpoints (
    stream TEXT PRIMARY KEY,
    frame INTEGER NOT NULL,
    t REAL NOT NULL,
    format INTEGER NOT NULL,
    blob BLOB NOT NULL
);
CREATE TABLE IF NOT EXISTS chunks (
    stream TEXT NOT NULL,
    digest BLOB NOT NULL,
    data BLOB NOT NULL,
    PRIMARY KEY (stream, digest)
);
"""


class CheckpointStore:
    """``<state_dir>/checkpoints.sqlite``: one row per open stream, written by a thread."""

    def __init__(self, state_dir):
        from pathlib import Path

        d = Path(state_dir)
        d.mkdir(parents=True, exist_ok=True)
        self.path = d / "checkpoints.sqlite"
        self._db = None
        try:
            self._open()
        except sqlite3.DatabaseError as err:  # e.g. torn by a power loss (synchronous OFF)
            aside = self.path.with_name(f"checkpoints.corrupt-{int(time.time())}.sqlite")
            log.warning(
                "%s is damaged (%s): moved to %s, no stream restored", self.path, err, aside.name
            )
            if self._db is not None:
                self._db.close()
            for suffix in ("", "-wal", "-shm"):
                src = Path(str(self.path) + suffix)
                if src.exists():
                    src.rename(str(aside) + suffix)
            self._open()
        self._queue: list = []  # ("put", stream, frame, state) or ("del", stream)
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._idle = threading.Event()
        self._idle.set()
        self._stopping = threading.Event()
        self.rounds = 0
        self.written = 0
        self.failed = 0  # writes that failed (disk full, unwritable): the daemon reports them
        self.paused = 0  # rounds not written: too little space left for the event log
        self.free_bytes = None  # the disk's free bytes at the last round
        self.bytes = 0
        self.write_seconds = 0.0
        self.cpu_seconds = 0.0
        self._thread = threading.Thread(target=self._run, name="streamseg-checkpoint", daemon=True)
        self._thread.start()

    def _open(self) -> None:
        self._db = connect(self.path)
        # a checkpoint is rewritten every few seconds and only matters after a crash of the
        # process, which synchronous OFF survives (the OS holds the writes); skipping the
        # fsyncs of the WAL checkpoints took the store's p99 cost at 250 streams from +45 %
        # to +9 % (0d6c5cf:benchmarks/daemon_throughput.py). A power loss may tear the file: it is
        # then moved aside at the next start. The event log keeps synchronous NORMAL.
        self._db.execute("PRAGMA synchronous=OFF")
        self._db.execute("PRAGMA journal_size_limit=0")  # a WAL truncated whenever reset
        self._db.executescript(SCHEMA)
        self._db.execute("DELETE FROM chunks WHERE stream NOT IN (SELECT stream FROM checkpoints)")
        # the digests stored per stream (writer thread): a round inserts only the others
        self._stored: dict[str, set] = collections.defaultdict(set)
        for stream, digest in self._db.execute("SELECT stream, digest FROM chunks"):
            self._stored[stream].add(digest)

    def read_all(self) -> list:
        """``[(stream, state)]`` of every stored checkpoint (unreadable ones skipped)."""
        out = []
        for stream, fmt, blob in self._db.execute("SELECT stream, format, blob FROM checkpoints"):
            if fmt not in READS:
                log.error(
                    "checkpoint of %s in %s has format %s; this release reads formats "
                    "%s: not restored (its take is closed)",
                    stream,
                    self.path,
                    fmt,
                    ", ".join(map(str, READS)),
                )
                continue
            try:
                chunks = dict(
                    self._db.execute("SELECT digest, data FROM chunks WHERE stream = ?", (stream,))
                )
                out.append(
                    (
                        stream,
                        load(msgpack.unpackb(blob, raw=False, strict_map_key=False), chunks, fmt),
                    )
                )
            except StateVersionError as err:  # written by a newer release
                log.error(
                    "checkpoint of %s in %s: %s: not restored (its take is closed)",
                    stream,
                    self.path,
                    err,
                )
            except Exception as err:  # a damaged row must not stop the daemon
                log.error(
                    "checkpoint of %s unreadable (%s: %s): not restored",
                    stream,
                    type(err).__name__,
                    err,
                )
        return out

    def put(self, items: list) -> None:
        """Queue ``[(stream, frame, state)]`` (states from :func:`dump`) for writing."""
        with self._lock:
            self._queue += [("put", *it) for it in items]
            self._idle.clear()
        self._wake.set()

    def forget(self, stream: str) -> None:
        with self._lock:
            self._queue.append(("del", stream))
            self._idle.clear()
        self._wake.set()

    def busy(self) -> bool:
        return not self._idle.is_set()

    def wait(self, timeout: float = 30.0) -> bool:
        """Block until everything queued is committed."""
        return self._idle.wait(timeout)

    def close(self, timeout: float = 30.0) -> None:
        self._stopping.set()
        self._wake.set()
        self._thread.join(timeout)
        if not self._thread.is_alive():
            self._db.close()

    def _run(self) -> None:
        # below the loop and the relabels in the OS scheduler (Linux: nice is per thread): when
        # the cores are saturated, checkpoints come later instead of delaying packets
        try:
            tid = threading.get_native_id()
            os.setpriority(
                os.PRIO_PROCESS, tid, min(19, os.getpriority(os.PRIO_PROCESS, tid) + NICE)
            )
        except (AttributeError, OSError):
            pass
        while True:
            self._wake.wait()  # until put, forget or close
            self._wake.clear()
            with self._lock:
                batch, self._queue = self._queue, []
            if batch:
                self._write(batch)
            with self._lock:
                if not self._queue:
                    self._idle.set()
            if self._stopping.is_set() and not self._queue:
                return

    def _write(self, batch: list) -> None:
        t0, c0 = time.perf_counter(), time.thread_time()
        rows, gone = {}, set()
        for op in batch:  # the newest state of each stream wins; a forget after it too
            if op[0] == "put":
                rows[op[1]] = op
                gone.discard(op[1])
            else:
                rows.pop(op[1], None)
                gone.add(op[1])
        try:
            packed, new_chunks, dead, kept = [], [], [], {}
            for _, stream, frame, state in rows.values():
                t1 = time.perf_counter()
                chunks: dict = {}
                pause = _breathe if BREATHE else None
                blob = msgpack.packb(packable(state, chunks, pause), use_bin_type=True)
                old = self._stored.get(stream, set())
                fresh = [(stream, d, stored(chunks[d])) for d in chunks.keys() - old]
                new_chunks += fresh
                dead += [(stream, d) for d in old - chunks.keys()]
                kept[stream] = set(chunks)
                self.bytes += len(blob) + sum(len(c[2]) for c in fresh)
                packed.append((stream, frame, time.time(), FORMAT, blob))
                # packing holds the GIL and a core: as long a pause as the packing took, so a
                # round of many streams never takes the loop's core in one burst
                time.sleep(min(time.perf_counter() - t1, 0.005) * PACE)
            size = sum(len(p[4]) for p in packed) + sum(len(c[2]) for c in new_chunks)
            self.free_bytes = shutil.disk_usage(self.path.parent).free
            if packed and self.free_bytes < 2 * size + LOW_WATER:
                if not self.paused:
                    log.warning(
                        "checkpoints %s paused: %.1f MB free on its disk, the event "
                        "log has priority (%.0f MB kept free for it); they resume "
                        "when there is room",
                        self.path,
                        self.free_bytes / 1e6,
                        LOW_WATER / 1e6,
                    )
                self.paused += 1
                packed, new_chunks, dead, kept = [], [], [], {}  # the deletes still go in
            self._db.execute("BEGIN")
            self._db.executemany(
                "INSERT OR REPLACE INTO checkpoints VALUES (?, ?, ?, ?, ?)", packed
            )
            self._db.executemany("INSERT OR IGNORE INTO chunks VALUES (?, ?, ?)", new_chunks)
            self._db.executemany("DELETE FROM chunks WHERE stream = ? AND digest = ?", dead)
            self._db.executemany("DELETE FROM checkpoints WHERE stream = ?", [(s,) for s in gone])
            self._db.executemany("DELETE FROM chunks WHERE stream = ?", [(s,) for s in gone])
            self._db.execute("COMMIT")
            self._stored.update(kept)
            for s in gone:
                self._stored.pop(s, None)
            self.written += len(packed)
            # the WAL's pages into the file and the WAL emptied (synchronous OFF: no fsync)
            self._db.execute("PRAGMA wal_checkpoint(TRUNCATE)").fetchall()
        except (sqlite3.Error, TypeError, ValueError, OverflowError) as err:
            log.error("checkpoints %s: %d not written: %s", self.path, len(rows), err)
            self.failed += 1
            try:
                self._db.execute("ROLLBACK")
            except sqlite3.Error:
                pass
        self.rounds += 1
        self.write_seconds += time.perf_counter() - t0
        self.cpu_seconds += time.thread_time() - c0  # the writer's own CPU, not its pauses


def open_store(config) -> CheckpointStore | None:
    if not config.state_dir or config.state_dir == "none" or not config.checkpoint_interval:
        return None
    return CheckpointStore(config.state_dir)
