"""The checkpoint store on a real SQLite file: a stream's state round-trips exactly, a round
stores only the chunks that changed, and no chunk outlives the checkpoints that use it."""

from __future__ import annotations

import sqlite3

import numpy as np
import pytest

from streamseg.daemon.algorithms import Algorithms
from streamseg.daemon.checkpoint import snapshot
from streamseg.daemon.checkpoint_store import CheckpointStore
from streamseg.daemon.pipeline import StreamPipeline
from streamseg.daemon.state_codec import CHUNK
from streamseg.daemon.streams import StreamState

STEP = 240  # 2 s at 120 Hz: the frames between two periodic checkpoints


@pytest.fixture(scope="module")
def algorithms(warm_kernels):
    return Algorithms()


def stream(rec, algorithms, n, name="s"):
    """A stream that has taken frames ``0 .. n - 1`` of ``rec`` (looped)."""
    p = StreamPipeline(rec.skeleton, rec.fps, algorithms, 60.0)
    p.push(rec.positions[np.arange(n) % rec.n_frames], 0)
    st = StreamState(name, 1, rec.fps, p, 0.0)
    st.next_seq = n
    return st


def more(st, rec, n):
    """Feed the next ``n`` frames; returns the cuts they gave."""
    a = st.next_seq
    cuts, _, _ = st.pipeline.push(rec.positions[np.arange(a, a + n) % rec.n_frames], a)
    st.next_seq = a + n
    return cuts


def store_bytes(store, items):
    before = store.bytes
    store.put(items)
    assert store.wait()
    return store.bytes - before


def chunk_rows(path):
    con = sqlite3.connect(path)
    try:
        return con.execute("SELECT stream, count(*) FROM chunks GROUP BY stream").fetchall()
    finally:
        con.close()


def through_sqlite(tmp_path, st, algorithms):
    """``(name, state)`` of stream ``st`` checkpointed into a store under ``tmp_path`` and
    read back by another store, as a restart does (its pipeline given ``algorithms``)."""
    store = CheckpointStore(tmp_path)
    store.put([(st.stream, st.next_seq, snapshot(st))])
    assert store.wait()
    store.close()
    ((name, state),) = CheckpointStore(tmp_path).read_all()
    back = state["pipeline"]
    back.algorithms, back.plan = algorithms, algorithms.prepare(back.skeleton)
    return name, state


def test_a_restored_stream_continues_exactly_as_the_original(tmp_path, rec, algorithms):
    st = stream(rec, algorithms, 7200)
    name, state = through_sqlite(tmp_path, st, algorithms)
    back = state["pipeline"]
    assert name == "s" and state["stream"].next_seq == 7200
    np.testing.assert_array_equal(back._feat, st.pipeline._feat)
    np.testing.assert_array_equal(back._frames, st.pipeline._frames)
    # the detector's neighbour lists, lrd and LOF are not stored but rebuilt, bit for bit
    assert "_nn_d" not in snapshot(st)["__d__"][1][1]["s"]["segmenter"]["s"]
    live, again = st.pipeline.segmenter, back.segmenter
    assert again.buffer_lof().size == live.buffer_lof().size > 100
    np.testing.assert_array_equal(again.buffer_lof(), live.buffer_lof())
    np.testing.assert_array_equal(again._lrd, live._lrd)
    twin = StreamState("s", 1, rec.fps, back, 0.0)
    twin.next_seq = st.next_seq
    # the detector's whole state came back: the next 10 s give the same cuts
    cuts = more(st, rec, 1200)
    assert cuts and more(twin, rec, 1200) == cuts


def test_a_round_stores_only_the_chunks_that_changed(tmp_path, rec, algorithms):
    st = stream(rec, algorithms, 7200)
    store = CheckpointStore(tmp_path)
    first = store_bytes(store, [("s", st.next_seq, snapshot(st))])
    more(st, rec, STEP)
    second = store_bytes(store, [("s", st.next_seq, snapshot(st))])
    # the full state is ~700 kB; 2 s of frames change the ring's newest rows and part of
    # the detector (measured 62 kB, benchmarks/daemon_faults.py)
    assert first > 600_000
    assert second < first / 4
    # the old chunks that no checkpoint uses any more went in the same transaction
    rows = chunk_rows(store.path)
    con = sqlite3.connect(store.path)
    stored = {d for (d,) in con.execute("SELECT digest FROM chunks WHERE stream = 's'")}
    con.close()
    assert rows == [("s", len(stored))] and stored == store._stored["s"]
    store.close()
    ((_, state),) = CheckpointStore(tmp_path).read_all()
    np.testing.assert_array_equal(state["pipeline"]._feat, st.pipeline._feat)


def test_a_young_stream_stores_little(tmp_path, rec, algorithms):
    # its buffers are unused zeros: not stored
    st = stream(rec, algorithms, 4)
    store = CheckpointStore(tmp_path)
    assert store_bytes(store, [("s", st.next_seq, snapshot(st))]) < 4 * CHUNK
    store.close()


def test_forget_removes_the_stream_and_its_chunks(tmp_path, rec, algorithms):
    a, b = stream(rec, algorithms, 2400, "a"), stream(rec, algorithms, 2400, "b")
    store = CheckpointStore(tmp_path)
    store.put([("a", a.next_seq, snapshot(a)), ("b", b.next_seq, snapshot(b))])
    store.forget("a")
    assert store.wait()
    assert [s for s, _ in chunk_rows(store.path)] == ["b"]
    store.close()
    assert [s for s, _ in CheckpointStore(tmp_path).read_all()] == ["b"]


def test_stray_chunks_go_at_open_and_a_damaged_row_is_skipped(tmp_path, rec, algorithms):
    st = stream(rec, algorithms, 2400)
    store = CheckpointStore(tmp_path)
    store.put([("s", st.next_seq, snapshot(st))])
    assert store.wait()
    store.close()
    con = sqlite3.connect(tmp_path / "checkpoints.sqlite")
    with con:
        con.execute("INSERT INTO chunks VALUES ('gone', x'00', x'01')")  # no checkpoint row
        con.execute(
            "DELETE FROM chunks WHERE rowid = (SELECT min(rowid) FROM chunks WHERE stream = 's')"
        )
    con.close()
    store = CheckpointStore(tmp_path)
    assert [s for s, _ in chunk_rows(store.path)] == ["s"]
    assert store.read_all() == []  # a chunk is missing: not restored, no exception
    store.close()


def test_a_damaged_file_is_moved_aside_and_the_store_starts_empty(tmp_path, rec, algorithms):
    (tmp_path / "checkpoints.sqlite").write_bytes(b"not a database" * 1000)
    store = CheckpointStore(tmp_path)
    assert store.read_all() == []
    st = stream(rec, algorithms, 240)
    store.put([("s", st.next_seq, snapshot(st))])
    assert store.wait()
    store.close()
    assert [s for s, _ in CheckpointStore(tmp_path).read_all()] == ["s"]
    aside = list(tmp_path.glob("checkpoints.corrupt-*.sqlite"))
    assert len(aside) == 1 and aside[0].read_bytes().startswith(b"not a database")


@pytest.mark.daemon
def test_rounds_space_out_when_they_cost_more_than_the_cpu_budget(
    tmp_path, rec, start_daemon, monkeypatch
):
    """Once a round is written, the next one waits for that round's own cost / CPU_BUDGET
    after it began (at least the configured interval), and ``stats`` says the spacing in
    force."""
    import zmq

    from streamseg import protocol as P
    from streamseg.client import request
    from streamseg.commands.replay import announce_of
    from streamseg.daemon import checkpoint as ck

    monkeypatch.setattr(ck, "CPU_BUDGET", 1e-7)  # any real round costs far more than this
    d, ep = start_daemon(state_dir=str(tmp_path / "state"), checkpoint_interval=0.05)
    totals = request(ep["control"], "stats")["totals"]
    assert totals["checkpoint_interval_s"] == 0.05
    sock = zmq.Context.instance().socket(zmq.PUSH)
    sock.connect(ep["ingest"])
    sock.send_multipart(P.encode(announce_of(rec, "b")))
    sock.send_multipart(P.encode(P.Frames("b", 0, 0.0, rec.positions[:240])))
    for _ in range(3000):  # the first round (interval 0.05 s) writes the stream; once it is
        totals = request(ep["control"], "stats")["totals"]  # written, its cost sets the gap
        if totals["checkpoint_interval_s"] > 0.05:
            break
    assert d.checkpoints.written >= 1
    assert totals["checkpoints"] == totals["checkpoints_written"] == 1  # copied, committed
    # cost / 1e-7: a round of one small stream costs tens of microseconds at least
    assert totals["checkpoint_interval_s"] > 10.0
    assert d.checkpoints.rounds == 1  # and no second round began
    sock.close(linger=1000)
