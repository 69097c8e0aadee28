"""Checkpoints: every open stream's state in ``<state_dir>/checkpoints.sqlite``, restored at
start, so a daemon killed with -9 and restarted on the same state directory resumes its
streams where the last checkpoint left them.

A checkpoint holds the stream's bookkeeping (announce, next expected frame, counters, the last
``segments`` and recent cuts) and its pipeline: the cut detector's arrays, the feature ring
the relabels read, the last relabel result (stream-wide ids). The loop thread copies the state
(:func:`dump`: arrays become bytes, nothing is shared with the live stream) every
``checkpoint_interval`` seconds for the streams that received frames since their last one;
a writer thread packs them (msgpack) and stores them in one transaction. No pickle: only
plain values, numpy arrays and objects of ``streamseg`` classes (rebuilt field by field) are
written or read.

Arrays larger than :data:`CHUNK` bytes are stored as content-addressed chunks (SHA-1 of
:data:`CHUNK` bytes each, per stream): a round writes only the chunks whose content changed
since the stream's previous checkpoint. Most of a stream's state is its feature ring (547 of
703 kB at 60 s x 120 Hz), of which a 2 s interval rewrites 2 s worth, so a full stream's
round writes about a fifth of its state instead of all of it; a young stream's unused
(zero) buffers are one chunk. Chunks no checkpoint refers to are deleted in the same
transaction.
"""

from __future__ import annotations

import collections
import hashlib
import importlib
import logging
import sqlite3
import threading
import time

import msgpack
import numpy as np

from streamseg.daemon import limits
from streamseg.daemon.eventlog import connect
from streamseg.daemon.pipeline import StreamPipeline
from streamseg.daemon.streams import StreamState

log = logging.getLogger("streamseg.daemon")

SEQ_SKIP = 1000  # event numbers skipped after a crash (see restore)
FORMAT = 3  # of the checkpoint blobs; another value is ignored at restore (with a warning)
CHUNK = 4096  # bytes of an array chunk: smaller ones store less per round, more rows
SKIP = {StreamPipeline: ("algorithms", "plan"),
        StreamState: ("pipeline", "pending", "arrivals", "gap_limit")}


# --- a small, closed serialisation (no pickle) ----------------------------------------------

def dump(obj):
    """A msgpack-able copy of ``obj``: plain values, arrays (as bytes), deques, tuples and
    objects of ``streamseg`` classes (their ``__dict__`` / ``__slots__``)."""
    if obj is None or isinstance(obj, (bool, int, float, str, bytes)):
        return obj
    if isinstance(obj, np.ndarray):  # a copy; the writer thread turns it into bytes (trimmed)
        return {"__nd__": [obj.dtype.str, list(obj.shape), np.array(obj, order="C")]}
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, list):
        return [dump(x) for x in obj]
    if isinstance(obj, tuple):
        return {"__t__": [dump(x) for x in obj]}
    if isinstance(obj, collections.deque):
        return {"__dq__": [obj.maxlen, [dump(x) for x in obj]]}
    if isinstance(obj, dict):
        return {"__d__": [[dump(k), dump(v)] for k, v in obj.items()]}
    cls = type(obj)
    if not cls.__module__.startswith("streamseg."):
        raise TypeError(f"cannot checkpoint a {cls.__module__}.{cls.__qualname__}")
    skip = SKIP.get(cls, ())
    names = [n for c in cls.__mro__ for n in getattr(c, "__slots__", ())]
    if hasattr(obj, "__dict__"):
        names += list(vars(obj))
    state = {n: dump(getattr(obj, n)) for n in dict.fromkeys(names)
             if n not in skip and hasattr(obj, n)}
    return {"__obj__": f"{cls.__module__}:{cls.__qualname__}", "s": state}


def load(obj, chunks=None):
    """Inverse of :func:`dump` (and of :func:`packable`, given the stream's ``chunks``:
    a mapping of digest to bytes)."""
    if isinstance(obj, list):
        return [load(x, chunks) for x in obj]
    if not isinstance(obj, dict):
        return obj
    if "__nd__" in obj:
        dtype, shape, data = obj["__nd__"]
        if isinstance(data, np.ndarray):  # straight from dump
            return data.copy()
        dtype = np.dtype(dtype)
        n = int(np.prod(shape)) * dtype.itemsize
        if isinstance(data, list):  # chunk digests (packable), each without trailing zeros
            data = b"".join(chunks[d].ljust(min(CHUNK, n - i * CHUNK), b"\0")
                            for i, d in enumerate(data))
        return np.frombuffer(data.ljust(n, b"\0"), dtype=dtype).reshape(shape).copy()
    if "__t__" in obj:
        return tuple(load(x, chunks) for x in obj["__t__"])
    if "__dq__" in obj:
        maxlen, items = obj["__dq__"]
        return collections.deque((load(x, chunks) for x in items), maxlen=maxlen)
    if "__d__" in obj:
        return {load(k, chunks): load(v, chunks) for k, v in obj["__d__"]}
    if "__obj__" in obj:
        module, qual = obj["__obj__"].split(":")
        if not module.startswith("streamseg."):
            raise TypeError(f"refusing to build {module}.{qual} from a checkpoint")
        cls = importlib.import_module(module)
        for part in qual.split("."):
            cls = getattr(cls, part)
        out = cls.__new__(cls)
        for k, v in obj["s"].items():
            object.__setattr__(out, k, load(v, chunks))  # also frozen dataclasses
        return out
    raise TypeError(f"unknown checkpoint value with keys {sorted(obj)[:5]}")


def packable(obj, chunks: dict):
    """:func:`dump`'s output with its arrays as bytes; an array of more than :data:`CHUNK`
    bytes becomes the list of its chunks' digests, and ``chunks`` gains ``{digest: bytes}``
    (trailing zero bytes dropped). Writer thread."""
    if isinstance(obj, list):
        return [packable(x, chunks) for x in obj]
    if not isinstance(obj, dict):
        return obj
    if "__nd__" in obj:
        dtype, shape, a = obj["__nd__"]
        raw = memoryview(a.reshape(-1)).cast("B")
        if raw.nbytes <= CHUNK:
            return {"__nd__": [dtype, shape, raw.tobytes().rstrip(b"\0")]}
        digests = []
        for i in range(0, raw.nbytes, CHUNK):
            # trailing zero bytes are not stored: a young stream's buffers are mostly unused
            part = raw[i:i + CHUNK].tobytes().rstrip(b"\0")
            # content addressing, not security: a changed chunk gets a new key
            d = hashlib.sha1(part, usedforsecurity=False).digest()
            chunks[d] = part
            digests.append(d)
        return {"__nd__": [dtype, shape, digests]}
    return {k: packable(v, chunks) for k, v in obj.items()}


# --- the store ---------------------------------------------------------------------------------

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
        self._db = connect(self.path)
        self._db.executescript(SCHEMA)
        self._db.execute("DELETE FROM chunks WHERE stream NOT IN (SELECT stream FROM checkpoints)")
        # the digests stored per stream (writer thread): a round inserts only the others
        self._stored: dict[str, set] = collections.defaultdict(set)
        for stream, digest in self._db.execute("SELECT stream, digest FROM chunks"):
            self._stored[stream].add(digest)
        self._queue: list = []  # ("put", stream, frame, state) or ("del", stream)
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._idle = threading.Event()
        self._idle.set()
        self._stopping = threading.Event()
        self.rounds = 0
        self.written = 0
        self.bytes = 0
        self.write_seconds = 0.0
        self._thread = threading.Thread(target=self._run, name="streamseg-checkpoint",
                                        daemon=True)
        self._thread.start()

    def read_all(self) -> list:
        """``[(stream, state)]`` of every stored checkpoint (unreadable ones skipped)."""
        out = []
        for stream, fmt, blob in self._db.execute("SELECT stream, format, blob FROM checkpoints"):
            if fmt != FORMAT:
                log.warning("checkpoint of %s has format %s, not %s: not restored", stream, fmt,
                            FORMAT)
                continue
            try:
                chunks = dict(self._db.execute("SELECT digest, data FROM chunks WHERE stream = ?",
                                               (stream,)))
                out.append((stream, load(msgpack.unpackb(blob, raw=False,
                                                         strict_map_key=False), chunks)))
            except Exception as err:  # a damaged row must not stop the daemon
                log.error("checkpoint of %s unreadable (%s: %s): not restored", stream,
                          type(err).__name__, err)
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
        t0 = time.perf_counter()
        rows, gone = {}, set()
        for op in batch:  # the newest state of each stream wins; a forget after it too
            if op[0] == "put":
                rows[op[1]] = op
                gone.discard(op[1])
            else:
                rows.pop(op[1], None)
                gone.add(op[1])
        try:
            packed, new_chunks, dead, stored = [], [], [], {}
            for _, stream, frame, state in rows.values():
                chunks: dict = {}
                blob = msgpack.packb(packable(state, chunks), use_bin_type=True)
                old = self._stored.get(stream, set())
                fresh = [(stream, d, chunks[d]) for d in chunks.keys() - old]
                new_chunks += fresh
                dead += [(stream, d) for d in old - chunks.keys()]
                stored[stream] = set(chunks)
                self.bytes += len(blob) + sum(len(c[2]) for c in fresh)
                packed.append((stream, frame, time.time(), FORMAT, blob))
                time.sleep(0)  # packing holds the GIL: let the loop thread in between streams
            self._db.execute("BEGIN")
            self._db.executemany("INSERT OR REPLACE INTO checkpoints VALUES (?, ?, ?, ?, ?)",
                                 packed)
            self._db.executemany("INSERT OR IGNORE INTO chunks VALUES (?, ?, ?)", new_chunks)
            self._db.executemany("DELETE FROM chunks WHERE stream = ? AND digest = ?", dead)
            self._db.executemany("DELETE FROM checkpoints WHERE stream = ?",
                                 [(s,) for s in gone])
            self._db.executemany("DELETE FROM chunks WHERE stream = ?", [(s,) for s in gone])
            self._db.execute("COMMIT")
            self._stored.update(stored)
            for s in gone:
                self._stored.pop(s, None)
            self.written += len(packed)
        except (sqlite3.Error, TypeError, ValueError, OverflowError) as err:
            log.error("checkpoints %s: %d not written: %s", self.path, len(rows), err)
            try:
                self._db.execute("ROLLBACK")
            except sqlite3.Error:
                pass
        self.rounds += 1
        self.write_seconds += time.perf_counter() - t0


def open_store(config) -> CheckpointStore | None:
    if not config.state_dir or config.state_dir == "none" or not config.checkpoint_interval:
        return None
    return CheckpointStore(config.state_dir)


# --- the daemon's side -------------------------------------------------------------------------

def snapshot(st: StreamState) -> dict:
    """A copy of one stream's state (the loop thread; no I/O)."""
    return dump({"stream": st, "pipeline": st.pipeline})


def checkpoint(daemon) -> int:
    """Queue a checkpoint of every open stream at once (the control op ``checkpoint``);
    returns how many."""
    store = daemon.checkpoints
    if store is None:
        return 0
    t0 = time.perf_counter()
    items = []
    daemon._ckpt_round = []
    for st in list(daemon.streams.values()):
        _copy(daemon, st, items)
    if items:
        store.put(items)
    daemon.totals["checkpoints"] += len(items)
    daemon.checkpoint_seconds += time.perf_counter() - t0
    return len(items)


STEP_BUDGET = 0.002  # seconds of loop time per step of a checkpoint round


def step(daemon, now: float) -> int:
    """One step of the periodic checkpoint: a round starts every ``checkpoint_interval`` s
    (unless the writer is still busy with the last one) with the streams that took frames
    since their last checkpoint; each step copies streams for at most ``STEP_BUDGET`` s, so
    with many streams the copying is spread over loop iterations instead of one long pause
    (500 streams x 0.1 ms would be 50 ms of added latency). Returns the streams copied."""
    store = daemon.checkpoints
    if not daemon._ckpt_round:
        if now < daemon._next_ckpt:
            return 0
        daemon._next_ckpt = now + daemon.config.checkpoint_interval
        if store.busy():
            return 0
        seen = daemon._ckpt_seen
        daemon._ckpt_round = [s for s, st in daemon.streams.items()
                              if st.frames_in != seen.get(s)]
    t0 = time.perf_counter()
    items = []
    while daemon._ckpt_round and time.perf_counter() - t0 < STEP_BUDGET:
        st = daemon.streams.get(daemon._ckpt_round.pop())
        if st is not None:
            _copy(daemon, st, items)
    if items:
        store.put(items)
    daemon.totals["checkpoints"] += len(items)
    daemon.checkpoint_seconds += time.perf_counter() - t0
    return len(items)


def _copy(daemon, st, items: list) -> None:
    daemon._flush(st)
    daemon._dirty.pop(st, None)
    try:
        items.append((st.stream, st.next_seq, snapshot(st)))
    except Exception as err:  # e.g. a custom algorithm with state we cannot copy
        daemon._error(st.stream, "checkpoint", f"stream state not checkpointed: "
                      f"{type(err).__name__}: {err}")
        return
    daemon._ckpt_seen[st.stream] = st.frames_in


def restore(daemon, now: float) -> int:
    """Open the checkpointed streams again (before the loop runs); returns how many."""
    store = daemon.checkpoints
    if store is None:
        return 0
    n = 0
    for stream, state in store.read_all():
        try:
            st = state["stream"]
            pipe = state["pipeline"]
            pipe.algorithms = daemon.algorithms
            pipe.plan = daemon.algorithms.prepare(pipe.skeleton)
            st.pipeline = pipe
            st.pending, st.arrivals = [], []
            st.gap_limit = limits.RateLimit(daemon.config.gap_events_per_s)
            st.last_seen = now
            daemon._gen += 1
            st.gen = daemon._gen
        except Exception as err:
            log.error("checkpoint of %s could not be restored (%s: %s)", stream,
                      type(err).__name__, err)
            continue
        daemon.streams[stream] = st
        daemon._ckpt_seen[stream] = st.frames_in
        # events published in the last moments before the crash may not have reached the log:
        # their numbers are skipped, never reused for other events
        daemon.numbering.last[stream] = daemon.numbering.current(stream) + SEQ_SKIP
        if st.client is not None:
            daemon.clients[st.client] += 1
        n += 1
        log.info("stream %s restored from its checkpoint at frame %d", stream, st.next_seq)
    daemon.totals["streams_restored"] += n
    return n
