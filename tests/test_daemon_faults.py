"""The fault catalogue over real sockets with the event log on (a real SQLite file): each
fault is counted and reported, the good stream's cuts are those of a run without it, and the
log holds every event published (benchmarks/daemon_faults.py measures the same faults)."""

from __future__ import annotations

import functools
import sqlite3
import threading
import time

import msgpack
import numpy as np
import pytest
import zmq

from streamseg import protocol as P
from streamseg.client import fetch_since, listen, request, subscribe
from streamseg.commands.replay import announce_of
from streamseg.daemon.algorithms import Algorithms
from streamseg.online.lof import StreamingLOFSegmenter
from tests.motion import lof_input
from tests.waiting import wait_until

pytestmark = pytest.mark.daemon
LOOP = "tcp://127.0.0.1:0"


@pytest.fixture(scope="module")
def want(rec):
    seg = StreamingLOFSegmenter(fps=rec.fps)
    ang = lof_input(rec.positions, rec.skeleton, rec.fps)
    return [c.frame for c in seg.learn_many(ang) + seg.finish()]


@pytest.fixture
def start_daemon(start_daemon, tmp_path):
    """The shared daemon starter, with an event log in this test's own folder."""
    return functools.partial(start_daemon, state_dir=str(tmp_path / "state"))


def good_stream(sock, rec, stream="good", step=20, between=None):
    """Send the recording as ``stream``; ``between(a)`` is called after each packet."""
    sock.send_multipart(P.encode(announce_of(rec, stream)))
    for a in range(0, rec.n_frames, step):
        sock.send_multipart(P.encode(P.Frames(stream, a, 0.0, rec.positions[a : a + step])))
        if between is not None:
            between(a)
    sock.send_multipart(P.encode(P.End(stream)))


def push(ep):
    s = zmq.Context.instance().socket(zmq.PUSH)
    s.setsockopt(zmq.LINGER, 5000)
    s.connect(ep["ingest"])
    return s


def cuts(events, stream="good"):
    return [e.frame for e in events if e.type == "cut" and e.stream == stream]


def logged_equal(ep, events, stream="good"):
    mine = [e for e in events if e.stream == stream]
    assert fetch_since(ep["control"], stream, 0) == mine


def test_huge_message_is_dropped_by_zeromq(start_daemon, rec, want):
    """A 40 MB message over a 1 MB cap never reaches the daemon (ZMQ_MAXMSGSIZE closes that
    connection); the good stream on another connection is untouched."""
    d, ep = start_daemon(max_message_bytes=1 << 20)
    s = subscribe(ep["publish"], ep["control"], stream="good")
    evil = push(ep)
    evil.send_multipart([b"frames/x/", b"\x00" * (40 << 20)])
    good = push(ep)
    good_stream(good, rec)
    events = list(listen(s, stream="good", until_end=True, timeout=30))
    assert cuts(events) == want
    assert request(ep["control"], "stats")["totals"]["packets"] == rec.n_frames // 20 + 3
    evil.close(linger=0)
    logged_equal(ep, events)


def test_poisoned_seq_is_an_error_not_a_gap(start_daemon, rec, want):
    d, ep = start_daemon()
    s = subscribe(ep["publish"], ep["control"], stream="good")
    sock = push(ep)
    poison = P.encode(P.Frames("good", 2**53 - 2, 0.0, rec.positions[:3]))

    def between(a):
        if a == 1000:
            sock.send_multipart(poison)

    good_stream(sock, rec, between=between)
    events = list(listen(s, stream="good", until_end=True, timeout=30))
    assert cuts(events) == want
    assert not [e for e in events if e.type == "gap"]
    err = [e for e in events if e.type == "error" and e.reason == "seq"]
    assert err and "max_seq_jump" in err[0].message
    assert request(ep["control"], "stats")["totals"]["errors_by_reason"] == {"seq": 1}
    logged_equal(ep, events)


def test_fps_and_clock_limits(start_daemon, rec):
    d, ep = start_daemon()
    s = subscribe(ep["publish"], ep["control"])
    sock = push(ep)
    tiny = P.encode(announce_of(rec, "tiny"))
    body = msgpack.unpackb(tiny[1])
    body["fps"] = 5e-324
    sock.send_multipart([tiny[0], msgpack.packb(body)])
    sock.send_multipart(P.encode(announce_of(rec, "clock")))
    sock.send_multipart(P.encode(P.Frames("clock", 0, float("inf"), rec.positions[:10])))
    sock.send_multipart(P.encode(P.Frames("clock", 0, 1e300, rec.positions[:10])))
    sock.send_multipart(P.encode(P.Frames("clock", 0, 0.0, rec.positions[:10])))
    sock.send_multipart(P.encode(P.End("clock")))
    events = []
    for e in listen(s, timeout=10):
        events.append(e)
        if e.type == "closed":
            break
    errs = [(e.stream, e.reason) for e in events if e.type == "error"]
    assert ("tiny", "field") in errs and ("clock", "field") in errs
    assert "tiny" not in {x["stream"] for x in request(ep["control"], "streams")["streams"]}
    assert events[-1] == P.Closed("clock", "end", 10)  # the good packet was kept
    assert request(ep["control"], "stats")["totals"]["errors_by_reason"]["field"] == 3


def test_gap_and_unknown_stream_floods_are_rate_limited(start_daemon, rec, want):
    # rates so low that the bursts' event counts do not depend on how fast this machine
    # takes them: one event each (the bucket's burst), then one per 1,000 s
    d, ep = start_daemon(gap_events_per_s=1e-3, stray_errors_per_s=1e-3, heartbeat=0.1)
    s = subscribe(ep["publish"], ep["control"])
    sock = push(ep)
    n_ids = 2000
    for k in range(n_ids):
        sock.send_multipart(P.encode(P.Frames(f"ghost{k}", 0, 0.0, rec.positions[:1])))
    sock.send_multipart(P.encode(announce_of(rec, "holes")))
    for a in range(0, 2400, 10):
        if (a // 10) % 2 == 0:  # every other packet lost: 119 gaps
            sock.send_multipart(P.encode(P.Frames("holes", a, 0.0, rec.positions[a : a + 10])))
    sock.send_multipart(P.encode(P.End("holes")))
    good_stream(sock, rec)
    events = []
    for e in listen(s, timeout=30):
        events.append(e)
        if e.type == "closed" and e.stream == "good":
            break
    assert cuts(events) == want
    ghosts = [e for e in events if e.type == "error" and e.reason == "unknown_stream" and e.stream]
    assert len(ghosts) == 1  # not one per id
    totals = request(ep["control"], "stats")["totals"]
    assert totals["errors_by_reason"]["unknown_stream"] == n_ids  # every one counted

    # the heartbeats' summaries (the loop beats between slices of the burst: one or more,
    # each with the count so far) come to every id that had no event of its own
    def pooled(e):
        return e.type == "error" and e.stream is None and e.reason == "unknown_stream"

    summed = max((e.count for e in events if pooled(e)), default=0)
    deadline = time.monotonic() + 10
    while summed < n_ids - len(ghosts) and time.monotonic() < deadline:
        e = next(listen(s, timeout=10))
        summed = max(summed, e.count) if pooled(e) else summed
    assert summed >= n_ids - len(ghosts)
    gaps = [e for e in events if e.type == "gap" and e.stream == "holes"]
    assert len(gaps) == 1  # the rest counted in the `gap` error below
    gap_err = [e for e in events if e.type == "error" and e.stream == "holes" and e.reason == "gap"]
    assert gap_err and gap_err[-1].count == 119  # counted, summarised before `closed`


def test_alternating_gaps_relabel_without_errors(start_daemon, rec):
    d, ep = start_daemon(relabel_interval=1.0, relabel_history=10.0, gap_events_per_s=1e6)
    s = subscribe(ep["publish"], ep["control"], stream="alt")
    sock = push(ep)
    sock.send_multipart(P.encode(announce_of(rec, "alt")))
    for a in range(0, rec.n_frames, 5):
        if (a // 5) % 2 == 0:
            sock.send_multipart(P.encode(P.Frames("alt", a, 0.0, rec.positions[a : a + 5])))
    sock.send_multipart(P.encode(P.End("alt")))
    events = list(listen(s, stream="alt", until_end=True, timeout=60))
    assert not [e for e in events if e.type == "error" and e.reason in ("relabel", "pipeline")]
    segs = [e for e in events if e.type == "segments"]
    assert segs and segs[-1].final


def test_stop_during_a_relabel_publishes_final_events(start_daemon, rec, tmp_path):
    """SIGTERM's path (Daemon.stop) while a relabel runs: the final cuts, a final segments
    and closed are published and logged."""
    serving, started, release = threading.Event(), threading.Event(), threading.Event()

    def slow_relabel(features, *, start_frame, fps, config, previous):
        from streamseg.config import ACAConfig
        from streamseg.offline import relabel_window

        if serving.is_set():  # a job of the stream, not the warm-up call before serving
            started.set()
            release.wait(60)  # the first job runs until the stop was asked
        return relabel_window(
            features, start_frame=start_frame, fps=fps, config=ACAConfig(), previous=previous
        )

    # relabel_share = 1: no pause between jobs (with 0.25 the worker would rest 3x this job's
    # time); shutdown_relabel = 60: on a loaded machine the running job and the final one
    # may take more than the default 5 s bound, after which `closed` comes without them
    d, ep = start_daemon(
        Algorithms(relabel=slow_relabel),
        relabel_interval=2.0,
        relabel_history=6.0,
        relabel_share=1.0,
        shutdown_relabel=60.0,
    )
    serving.set()
    s = subscribe(ep["publish"], ep["control"], stream="good")
    sock = push(ep)
    sock.send_multipart(P.encode(announce_of(rec, "good")))
    for a in range(0, 3000, 20):
        sock.send_multipart(P.encode(P.Frames("good", a, 0.0, rec.positions[a : a + 20])))
    assert started.wait(30)

    def taken_while_busy():
        st = request(ep["control"], "streams")["streams"]
        return st and st[0]["frame"] == 3000 and d.worker.busy_key is not None

    wait_until(taken_while_busy, "every frame taken, with the relabel running")
    d.stop()
    release.set()
    events = list(listen(s, stream="good", until_end=True, timeout=30))
    assert events[-1].type == "closed" and events[-1].reason == "shutdown"
    assert [e for e in events if e.type == "segments" and e.final]
    assert events[-1].frames == 3000

    # the log file holds them (the daemon has stopped: read the SQLite file itself)
    def logged_types():
        con = sqlite3.connect(tmp_path / "state" / "events.sqlite")
        types = [
            r[0] for r in con.execute("SELECT type FROM events WHERE stream = 'good' ORDER BY seq")
        ]
        con.close()
        return types if types and types[-1] == "closed" else None

    types = wait_until(logged_types, "the log file ends with the stream's closed")
    assert types[-len(events) :] == [e.type for e in events]


def test_nan_and_garbage_keep_every_good_frame_with_the_log_on(start_daemon, rec, want):
    d, ep = start_daemon()
    s = subscribe(ep["publish"], ep["control"], stream="good")
    sock = push(ep)
    rng = np.random.default_rng(0)

    def between(a):
        if a % 400 == 0:
            sock.send_multipart([b"frames/good/", rng.bytes(64)])
            sock.send_multipart([b"x"])

    good_stream(sock, rec, between=between)
    events = list(listen(s, stream="good", until_end=True, timeout=30))
    assert cuts(events) == want
    logged_equal(ep, events)


def test_a_full_state_dir_is_reported_and_the_stream_goes_on(start_daemon, rec):
    d, ep = start_daemon(heartbeat=0.1, checkpoint_interval=0.05, gap_events_per_s=1e6)
    # the files cannot grow: SQLite's own "database or disk is full", as on a full disk (the
    # log's reserve of free pages given back first)
    d.eventlog._w.executescript("PRAGMA incremental_vacuum;")
    for con in (d.eventlog._w, d.checkpoints._db):
        cur = con.execute("PRAGMA page_count")
        pages = cur.fetchone()[0]
        cur.close()
        con.execute(f"PRAGMA max_page_count = {pages}").close()
    errors = subscribe(ep["publish"], ep["control"], kind="error")
    s = subscribe(ep["publish"], ep["control"], stream="full")
    sock = push(ep)
    sock.send_multipart(P.encode(announce_of(rec, "full")))
    for a in range(0, rec.n_frames, 5):  # every other packet lost: hundreds of gap events
        if (a // 5) % 2 == 0:
            sock.send_multipart(P.encode(P.Frames("full", a, 0.0, rec.positions[a : a + 5])))
    seen = {}
    for ev in listen(errors, timeout=30):
        if ev.stream is None and ev.reason in ("event_log", "checkpoint"):
            seen[ev.reason] = ev
            if len(seen) == 2:
                break
    assert "disk full" in seen["event_log"].message and seen["event_log"].count >= 1
    assert seen["checkpoint"].count >= 1
    totals = request(ep["control"], "stats")["totals"]["errors_by_reason"]
    assert totals["event_log"] >= 1 and totals["checkpoint"] >= 1
    # the daemon and the stream go on: live events to the end
    sock.send_multipart(P.encode(P.End("full")))
    events = list(listen(s, stream="full", until_end=True, timeout=30))
    assert events[-1].type == "closed" and events[-1].reason == "end"
    assert sum(e.type == "gap" for e in events) > 100


def test_a_busy_loop_holds_frames_for_fewer_pipeline_steps(start_daemon, rec, want):
    """With ``coalesce_load = 0`` the loop counts as busy from the start: each stream's frames
    wait until it holds ``coalesce_frames`` (the wait bound is out of reach here), and every
    frame still gives the cuts of a run without waiting."""
    d, ep = start_daemon(coalesce_load=0, coalesce_frames=48, coalesce_wait=3600.0)
    s = subscribe(ep["publish"], ep["control"])
    sock = push(ep)
    good_stream(sock, rec, step=4)
    events = []
    for e in listen(s, timeout=60):
        events.append(e)
        if e.type == "closed" and e.stream == "good":
            break
    assert cuts(events) == want
    totals = request(ep["control"], "stats")["totals"]
    assert totals["frames"] == rec.n_frames
    # each step but the last (the end's) holds at least 48 frames: 4-frame packets alone
    # would be n_frames / 4 steps
    assert totals["steps"] <= rec.n_frames // 48 + 1
