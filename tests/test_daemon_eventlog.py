"""Numbered events and the SQLite event log, over real sockets and a real SQLite file."""

from __future__ import annotations

import dataclasses
import functools
import json
import sqlite3
import threading
import time

import pytest
import zmq

from streamseg import protocol as P
from streamseg.cli import main
from streamseg.client import fetch_since, handshake, listen, request, subscribe
from streamseg.commands.replay import announce_of, replay
from streamseg.daemon.eventlog import EventLog

pytestmark = pytest.mark.daemon
LOOP = "tcp://127.0.0.1:0"


@pytest.fixture
def start_daemon(start_daemon, tmp_path):
    """The shared daemon starter, with an event log in this test's own folder."""
    return functools.partial(start_daemon, state_dir=str(tmp_path / "state"))


def wait_closed(ep, stream, timeout=30):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        state = request(ep["control"], "state", stream=stream)
        if state.get("closed"):
            return state
        time.sleep(0.02)
    raise AssertionError(f"stream {stream} not closed in {timeout} s")


def test_events_are_numbered_and_logged(start_daemon, rec, tmp_path):
    d, ep = start_daemon(relabel_interval=5.0, relabel_history=10.0)
    s = subscribe(ep["publish"], ep["control"], stream="n1")
    replay(rec, ep["ingest"], stream="n1", speed=0, batch=20)
    live = list(listen(s, stream="n1", until_end=True, timeout=30))
    assert [e.seq for e in live] == list(range(1, len(live) + 1))
    assert {e.type for e in live} >= {"cut", "segments", "closed"}
    logged = fetch_since(ep["control"], "n1", 0)
    assert logged == live and [e.seq for e in logged] == [e.seq for e in live]
    tail = fetch_since(ep["control"], "n1", 5)
    assert [e.seq for e in tail] == list(range(6, len(live) + 1))
    # a re-announced stream keeps counting: numbers never repeat for one id
    s2 = subscribe(ep["publish"], ep["control"], stream="n1")
    replay(dataclasses.replace(rec, positions=rec.positions[:600]), ep["ingest"],
           stream="n1", speed=0, batch=20)
    again = list(listen(s2, stream="n1", until_end=True, timeout=30))
    assert again[0].seq == len(live) + 1
    # the file is a real SQLite database in WAL mode
    db = tmp_path / "state" / "events.sqlite"
    con = sqlite3.connect(db)
    assert con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    d.stop()
    deadline = time.monotonic() + 10
    n = 0
    while time.monotonic() < deadline:  # the writer commits at shutdown
        n = con.execute("SELECT count(*) FROM events WHERE stream = 'n1'").fetchone()[0]
        if n == len(live) + len(again):
            break
        time.sleep(0.05)
    assert n == len(live) + len(again)
    con.close()


def test_slow_subscriber_sees_the_hole_and_fills_it(start_daemon, rec):
    """A subscriber that does not read loses events to the high-water marks; the sequence
    numbers show the hole and the log holds every event."""
    d, ep = start_daemon(hwm=1, heartbeat=0, gap_events_per_s=1e6)
    ctx = zmq.Context.instance()
    slow = ctx.socket(zmq.SUB)
    slow.setsockopt(zmq.RCVHWM, 1)
    slow.setsockopt(zmq.SUBSCRIBE, b"")
    slow.connect(ep["publish"])
    assert handshake(slow, ep["control"]) == []  # live, nothing published yet
    sock = ctx.socket(zmq.PUSH)
    sock.connect(ep["ingest"])
    sock.send_multipart(P.encode(announce_of(rec, "h")))
    # every other packet is missing: a burst of gap events
    for a in range(0, 2400, 20):
        if (a // 20) % 2 == 0:
            sock.send_multipart(P.encode(P.Frames("h", a, 0.0, rec.positions[a:a + 20])))
    sock.send_multipart(P.encode(P.End("h")))
    sock.close(linger=5000)
    wait_closed(ep, "h")
    got = []
    while slow.poll(200):
        got.append(P.decode(slow.recv_multipart()))
    first_close = fetch_since(ep["control"], "h", 0)[-1].seq
    # the stream again: its events continue the numbers, and reach the now idle subscriber
    sock = ctx.socket(zmq.PUSH)
    sock.connect(ep["ingest"])
    sock.send_multipart(P.encode(announce_of(rec, "h")))
    sock.send_multipart(P.encode(P.End("h")))
    sock.close(linger=5000)
    while slow.poll(10_000):
        ev = P.decode(slow.recv_multipart())
        got.append(ev)
        if ev.type == "closed" and ev.seq > first_close:
            break
    got = [e for e in got if e.stream == "h"]
    complete = fetch_since(ep["control"], "h", 0)
    while complete[-1].seq < got[-1].seq:  # the log is written a moment after publication
        complete = fetch_since(ep["control"], "h", 0)
    complete = [e for e in complete if e.seq <= first_close]  # the first take
    assert [e.seq for e in complete] == list(range(1, len(complete) + 1))
    assert complete[-1].type == "closed"
    assert sum(e.type == "gap" for e in complete) == 59
    first = [e for e in got if e.seq <= first_close]
    assert len(first) < len(complete), "the slow subscriber lost nothing: no hole to test"
    seqs = [e.seq for e in got]
    assert any(b > a + 1 for a, b in zip(seqs[:-1], seqs[1:]))  # the numbers show the hole
    by_seq = {e.seq: e for e in fetch_since(ep["control"], "h", 0)}
    assert all(by_seq[e.seq] == e for e in got)  # what arrived is what the log holds
    slow.close(linger=0)


def test_listen_since_cli_and_hole_report(start_daemon, rec, capsys):
    d, ep = start_daemon()
    replay(rec, ep["ingest"], stream="c1", speed=0, batch=50)
    wait_closed(ep, "c1")
    capsys.readouterr()
    rc = main(["listen", "--from", ep["publish"], "--control", ep["control"], "--stream", "c1",
               "--since", "2", "--jsonl", "--until-end", "--timeout", "20"])
    assert rc == 0
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    events = [x for x in lines if x["type"] != "state"]
    total = fetch_since(ep["control"], "c1", 0)
    assert [e["seq"] for e in events] == list(range(3, len(total) + 1))
    assert events[-1]["type"] == "closed"
    assert main(["listen", "--from", ep["publish"], "--since", "0"]) == 2
    assert "--since needs --control" in capsys.readouterr().err


def test_listen_since_says_what_the_log_cannot_give(start_daemon, rec, capsys, tmp_path):
    d, ep = start_daemon()
    replay(rec, ep["ingest"], stream="c2", speed=0, batch=50)
    wait_closed(ep, "c2")
    last = fetch_since(ep["control"], "c2", 0)[-1].seq
    base = ["listen", "--from", ep["publish"], "--control", ep["control"], "--stream", "c2",
            "--jsonl", "--idle", "0.5"]
    capsys.readouterr()
    # beyond the newest number: said, then the live events are followed (none come)
    assert main(base + ["--since", str(last + 100)]) == 1
    err = capsys.readouterr().err
    assert f"--since {last + 100}: the newest event of stream c2 is {last}" in err
    assert main(base + ["--since", str(last)]) == 1  # up to date: nothing to say
    assert "nothing to fetch" not in capsys.readouterr().err
    # below the retained range (the oldest rows gone, as retention deletes them)
    con = sqlite3.connect(tmp_path / "state" / "events.sqlite", timeout=30)
    with con:
        con.execute("DELETE FROM events WHERE stream = 'c2' AND seq <= 3")
    con.close()
    assert main(base + ["--since", "0", "--until-end"]) == 0
    out, err = capsys.readouterr()
    assert "events 1..3 of stream c2 are no longer in the event log" in err
    seqs = [json.loads(x).get("seq") for x in out.splitlines()]
    assert [n for n in seqs if n is not None] == list(range(4, last + 1))


def test_listen_until_end_on_a_closed_stream_stops_and_says_so(start_daemon, rec, capsys):
    """A stream already closed has nothing left to wait for: `listen --until-end` prints its
    state (closed, with the reason) and returns instead of waiting for a new announce."""
    d, ep = start_daemon()
    replay(rec, ep["ingest"], stream="c3", speed=0, batch=50)
    wait_closed(ep, "c3")
    capsys.readouterr()
    # a 30 s timeout: without the stop, listen would wait for it and return 1
    assert main(["listen", "--from", ep["publish"], "--control", ep["control"], "--stream",
                 "c3", "--until-end", "--timeout", "30"]) == 0
    out, err = capsys.readouterr()
    assert "[c3] state" in out and "closed (end)" in out
    assert "stream c3 is already closed (end): nothing to wait for" in err


def test_late_joiner_gets_every_cut_of_the_stream(start_daemon, rec, capsys):
    """Joining mid-stream, `listen --control --stream` prints every cut since the stream
    opened (from the log), then the live ones, each once."""
    d, ep = start_daemon(heartbeat=0)
    early = subscribe(ep["publish"], ep["control"], stream="lj")
    ctx = zmq.Context.instance()
    sock = ctx.socket(zmq.PUSH)
    sock.connect(ep["ingest"])
    sock.send_multipart(P.encode(announce_of(rec, "lj")))
    half = 2400
    for a in range(0, half, 20):
        sock.send_multipart(P.encode(P.Frames("lj", a, 0.0, rec.positions[a:a + 20])))
    seen = []
    for e in listen(early, timeout=20):  # until the first half's cuts are out
        seen.append(e)
        if e.type == "cut" and sum(x.type == "cut" for x in seen) >= 2:
            break
    out = {}
    lis = threading.Thread(target=lambda: out.setdefault("rc", main(
        ["listen", "--from", ep["publish"], "--control", ep["control"], "--stream", "lj",
         "--jsonl", "--until-end", "--timeout", "30"])))
    lis.start()
    printed = ""
    deadline = time.monotonic() + 20
    while '"type": "cut"' not in printed.replace('":"', '": "') and time.monotonic() < deadline:
        printed += capsys.readouterr().out  # it has subscribed and printed the backlog
        time.sleep(0.01)
    for a in range(half, rec.n_frames, 20):
        sock.send_multipart(P.encode(P.Frames("lj", a, 0.0, rec.positions[a:a + 20])))
    sock.send_multipart(P.encode(P.End("lj")))
    sock.close(linger=5000)
    complete = seen + list(listen(early, stream="lj", until_end=True, timeout=30))
    lis.join(40)
    assert out["rc"] == 0
    lines = [json.loads(x) for x in (printed + capsys.readouterr().out).splitlines()]
    events = [x for x in lines if x["type"] != "state"]
    assert [e["seq"] for e in events] == [e.seq for e in complete]
    assert [e["frame"] for e in events if e["type"] == "cut"] == \
        [e.frame for e in complete if e.type == "cut"]


def test_retention_by_size_and_age(tmp_path):
    log = EventLog(tmp_path, max_bytes=200_000, max_age=3600, flush_interval=0.01,
                   retention_interval=0.01)
    body = b"x" * 1000
    for i in range(1, 2001):
        log.append("s", i, "cut", body)
    deadline = time.monotonic() + 20
    while log.written < 2000 and time.monotonic() < deadline:
        time.sleep(0.01)
    passes = log.retentions
    while log.retentions < passes + 2 and time.monotonic() < deadline:  # one after the last
        time.sleep(0.01)
    assert log.deleted > 0 and 0 < log.live_bytes <= 200_000
    bodies, first = log.since("s", 0, 5000)
    assert first > 1 and len(bodies) == 2000 - first + 1  # the newest are kept, in order
    log.close()
    old = EventLog(tmp_path / "age", max_age=1e-3, flush_interval=0.01, retention_interval=0.01)
    old.append("s", 1, "cut", body)
    deadline = time.monotonic() + 20
    while old.deleted == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert old.deleted == 1 and old.since("s", 0)[0] == []
    old.close()
