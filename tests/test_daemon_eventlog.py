"""Numbered events and the SQLite event log, over real sockets and a real SQLite file."""

from __future__ import annotations

import dataclasses
import functools
import json
import sqlite3
import subprocess
import sys
import threading

import pytest
import zmq

from streamseg import protocol as P
from streamseg.cli import main
from streamseg.client import fetch_since, handshake, listen, request, subscribe, takes
from streamseg.commands.replay import announce_of, replay
from streamseg.daemon.eventlog import EventLog
from streamseg.online.lof import StreamingLOFSegmenter
from tests.cli_words import listen_to
from tests.motion import lof_input
from tests.waiting import wait_until

pytestmark = pytest.mark.daemon
LOOP = "tcp://127.0.0.1:0"


@pytest.fixture
def start_daemon(start_daemon, tmp_path):
    """The shared daemon starter, with an event log in this test's own folder."""
    return functools.partial(start_daemon, state_dir=str(tmp_path / "state"))


def wait_closed(ep, stream, timeout=30):
    """The stream's closed state, once its `closed` event is in the log (published: events
    go out once committed, and `state` says closed as the event is queued)."""

    def closed():
        # a daemon still working through a burst answers late (7-9 s after 6,000 packets in
        # test_a_lost_tail_shows_in_the_heartbeat): the request's bound is the wait's
        state = request(ep["control"], "state", stream=stream, timeout=timeout)
        if state.get("closed"):
            logged = fetch_since(ep["control"], stream, 0)
            if logged and logged[-1].type == "closed":
                return state
        return None

    return wait_until(closed, f"stream {stream} closed and its `closed` logged", timeout)


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
    replay(
        dataclasses.replace(rec, positions=rec.positions[:600]),
        ep["ingest"],
        stream="n1",
        speed=0,
        batch=20,
    )
    again = list(listen(s2, stream="n1", until_end=True, timeout=30))
    assert again[0].seq == len(live) + 1
    # the file is a real SQLite database in WAL mode
    db = tmp_path / "state" / "events.sqlite"
    con = sqlite3.connect(db)
    assert con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    d.stop()
    wait_until(  # the writer commits at shutdown
        lambda: (
            con.execute("SELECT count(*) FROM events WHERE stream = 'n1'").fetchone()[0]
            == len(live) + len(again)
        ),
        "every event of n1 committed",
        timeout=10,
    )
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
            sock.send_multipart(P.encode(P.Frames("h", a, 0.0, rec.positions[a : a + 20])))
    sock.send_multipart(P.encode(P.End("h")))
    sock.close(linger=5000)
    wait_closed(ep, "h")
    # what reached it so far: the frames before a hello of its own (any later ones are read
    # with the second take's events below)
    got = [P.decode(f) for f in handshake(slow, ep["control"])]
    first_close = fetch_since(ep["control"], "h", 0)[-1].seq
    # the stream again: its events continue the numbers, and reach the now idle subscriber
    sock = ctx.socket(zmq.PUSH)
    sock.connect(ep["ingest"])
    sock.send_multipart(P.encode(announce_of(rec, "h")))
    sock.send_multipart(P.encode(P.End("h")))
    sock.close(linger=5000)
    while slow.poll(10_000):
        ev = P.decode(slow.recv_multipart())
        if ev.type == "hello":  # one the handshake asked for again before the first came
            continue
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
    rc = main(
        [
            *listen_to(ep),
            "--stream",
            "c1",
            "--since",
            "2",
            "--jsonl",
            "--until-end",
            "--timeout",
            "20",
        ]
    )
    assert rc == 0
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    events = [x for x in lines if x["type"] != "state"]
    total = fetch_since(ep["control"], "c1", 0)
    assert [e["seq"] for e in events] == list(range(3, len(total) + 1))
    assert events[-1]["type"] == "closed"
    assert main(["listen", "--from", ep["publish"], "--since", "0"]) == 2
    assert "--since needs --control" in capsys.readouterr().err


def test_listen_since_without_stream_reads_every_streams_back(start_daemon, rec, capsys):
    """`listen --control EP --since N` without --stream: the logged events above N of every
    stream the log holds, stream by stream in the order they were first logged (the `logged`
    op lists them), then the live events, each once."""
    d, ep = start_daemon(heartbeat=0)  # no `stats` lines among the events
    for name in ("zb", "ya"):  # logged in this order, which is not the ids' order
        replay(rec, ep["ingest"], stream=name, speed=0, batch=50)
        wait_closed(ep, name)
    listed = request(ep["control"], "logged")
    assert [r["stream"] for r in listed["streams"]] == ["zb", "ya"] and not listed["more"]
    logged = {s: fetch_since(ep["control"], s, 0) for s in ("zb", "ya")}
    assert [(r["first"], r["last"]) for r in listed["streams"]] == [
        (1, logged[s][-1].seq) for s in ("zb", "ya")
    ]
    base = [
        *listen_to(ep),
        "--jsonl",
        "--idle",
        "30",
    ]
    capsys.readouterr()
    # the histories end closed: --until-end stops after them
    assert main(base + ["--since", "2", "--until-end"]) == 0
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert lines[0]["type"] == "streams"
    got = [(x["stream"], x["seq"]) for x in lines[1:]]
    assert got == [(s, e.seq) for s in ("zb", "ya") for e in logged[s][2:]]
    assert lines[1] == json.loads(json.dumps(P.to_json(logged["zb"][2])))
    # --type applies to the back too
    assert main(base + ["--since", "0", "--type", "closed", "--until-end"]) == 0
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert [(x["stream"], x["type"]) for x in lines[1:]] == [("zb", "closed"), ("ya", "closed")]
    # the back, then the live events of a new take, each once (a listener of its own
    # process: its first line comes once its subscription is live)
    proc = subprocess.Popen(
        [sys.executable, "-m", "streamseg.cli", *base, "--since", "0"],
        stdout=subprocess.PIPE,
        text=True,
    )
    got = []
    zb_last, ya_last = logged["zb"][-1].seq, logged["ya"][-1].seq

    def read_all() -> bool:  # ya's back whole and the new take's `closed` (either order)
        return any(g[:2] == ("ya", ya_last) for g in got) and any(
            g[0] == "zb" and g[1] > zb_last and g[2] == "closed" for g in got
        )

    try:
        assert json.loads(proc.stdout.readline())["type"] == "streams"
        replay(rec, ep["ingest"], stream="zb", speed=0, batch=50)
        while not read_all():
            x = json.loads(proc.stdout.readline())
            got.append((x["stream"], x["seq"], x["type"]))
    finally:
        proc.kill()
        proc.wait(10)
    got = [g[:2] for g in got]
    every = {s: fetch_since(ep["control"], s, 0) for s in ("zb", "ya")}
    assert len(every["zb"]) > len(logged["zb"])  # the new take is logged
    # each stream's events in order, each once; the back comes stream by stream (zb's
    # logged events, then ya's); zb's new events may come with its back or live, after it
    for s in ("zb", "ya"):
        assert [g for g in got if g[0] == s] == [(s, e.seq) for e in every[s]]
    n_zb = len(logged["zb"])
    assert got[:n_zb] == [("zb", e.seq) for e in logged["zb"]]
    ya_at = got.index(("ya", 1))
    assert got[ya_at : ya_at + len(logged["ya"])] == [("ya", e.seq) for e in logged["ya"]]
    capsys.readouterr()
    # beyond every stream's newest number: said in one line, then live events are followed
    newest = fetch_since(ep["control"], "zb", 0)[-1].seq
    assert main(base[:-1] + ["0.5", "--since", str(newest + 5)]) == 1
    err = capsys.readouterr().err
    assert f"--since {newest + 5}: the newest event number of any stream is {newest}" in err


def test_listen_since_without_a_log_says_so_and_follows(start_daemon, capsys):
    d, ep = start_daemon(state_dir="none", heartbeat=0)
    assert request(ep["control"], "logged") == {
        "ok": False,
        "v": P.PROTOCOL_VERSION,
        "error": "this daemon keeps no event log (start it with --state-dir DIR)",
    }
    capsys.readouterr()
    assert (
        main(
            [
                *listen_to(ep),
                "--since",
                "0",
                "--idle",
                "0.5",
            ]
        )
        == 1
    )  # nothing to follow: the idle limit ends it
    err = capsys.readouterr().err
    assert "--since: this daemon keeps no event log (start it with --state-dir DIR)" in err


def test_listen_since_says_what_the_log_cannot_give(start_daemon, rec, capsys, tmp_path):
    d, ep = start_daemon()
    replay(rec, ep["ingest"], stream="c2", speed=0, batch=50)
    wait_closed(ep, "c2")
    last = fetch_since(ep["control"], "c2", 0)[-1].seq
    base = [
        *listen_to(ep),
        "--stream",
        "c2",
        "--jsonl",
        "--idle",
        "0.5",
    ]
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
    assert (
        main(
            [
                *listen_to(ep),
                "--stream",
                "c3",
                "--until-end",
                "--timeout",
                "30",
            ]
        )
        == 0
    )
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
        sock.send_multipart(P.encode(P.Frames("lj", a, 0.0, rec.positions[a : a + 20])))
    seen = []
    for e in listen(early, timeout=20):  # until the first half's cuts are out
        seen.append(e)
        if e.type == "cut" and sum(x.type == "cut" for x in seen) >= 2:
            break
    out = {}
    lis = threading.Thread(
        target=lambda: out.setdefault(
            "rc",
            main(
                [
                    *listen_to(ep),
                    "--stream",
                    "lj",
                    "--jsonl",
                    "--until-end",
                    "--timeout",
                    "30",
                ]
            ),
        )
    )
    lis.start()
    printed = ""

    def backlog_printed():  # it has subscribed and printed the backlog
        nonlocal printed
        printed += capsys.readouterr().out
        return '"type": "cut"' in printed.replace('":"', '": "')

    wait_until(backlog_printed, "the listener printed the backlog's cuts", timeout=20)
    for a in range(half, rec.n_frames, 20):
        sock.send_multipart(P.encode(P.Frames("lj", a, 0.0, rec.positions[a : a + 20])))
    sock.send_multipart(P.encode(P.End("lj")))
    sock.close(linger=5000)
    complete = seen + list(listen(early, stream="lj", until_end=True, timeout=30))
    lis.join(40)
    assert out["rc"] == 0
    lines = [json.loads(x) for x in (printed + capsys.readouterr().out).splitlines()]
    events = [x for x in lines if x["type"] != "state"]
    assert [e["seq"] for e in events] == [e.seq for e in complete]
    assert [e["frame"] for e in events if e["type"] == "cut"] == [
        e.frame for e in complete if e.type == "cut"
    ]


def test_retention_by_size_and_age(tmp_path):
    log = EventLog(
        tmp_path, max_bytes=200_000, max_age=3600, flush_interval=0.01, retention_interval=0.01
    )
    body = b"x" * 1000
    for i in range(1, 2001):
        log.append("s", i, "cut", body)
    wait_until(lambda: log.written == 2000, "2000 events written", timeout=20)
    passes = log.retentions
    wait_until(lambda: log.retentions >= passes + 2, "a retention pass after the last write")
    assert log.deleted > 0 and 0 < log.live_bytes <= 200_000
    bodies, first = log.since("s", 0, 5000)
    assert first > 1 and len(bodies) == 2000 - first + 1  # the newest are kept, in order
    log.close()
    old = EventLog(tmp_path / "age", max_age=1e-3, flush_interval=0.01, retention_interval=0.01)
    old.append("s", 1, "cut", body)
    wait_until(lambda: old.deleted, "the old event deleted", timeout=20)
    assert old.deleted == 1 and old.since("s", 0)[0] == []
    old.close()


def offline_cuts(rec, positions):
    seg = StreamingLOFSegmenter(fps=rec.fps)
    ang = lof_input(positions, rec.skeleton, rec.fps)
    return [c.frame for c in seg.learn_many(ang) + seg.finish()]


def test_a_reannounced_stream_closes_before_the_new_take_publishes(start_daemon, rec):
    """A sender restarts its take (re-announce) while the old take's final relabel runs:
    the old take's `closed` comes before any event of the new take, live and in the log."""
    d, ep = start_daemon(relabel_interval=1.0, relabel_history=30.0)
    s = subscribe(ep["publish"], ep["control"], stream="r")
    first, second = rec.positions[:3000], rec.positions[1500:4500]
    sock = zmq.Context.instance().socket(zmq.PUSH)
    sock.setsockopt(zmq.LINGER, 5000)
    sock.connect(ep["ingest"])
    for pos in (first, second):  # the second announce right behind the first take's frames
        sock.send_multipart(P.encode(announce_of(rec, "r")))
        for a in range(0, pos.shape[0], 50):
            sock.send_multipart(P.encode(P.Frames("r", a, 0.0, pos[a : a + 50])))
    sock.send_multipart(P.encode(P.End("r")))
    live = []
    for ev in listen(s, stream="r", timeout=60):
        live.append(ev)
        if ev.type == "closed" and ev.reason == "end":
            break
    one, two = takes(live)
    assert one[-1].reason == "reannounced" and two[-1].reason == "end"
    # each take's detector cuts are its own frames' (in the order a consumer applies them;
    # cuts a relabel announced are not provisional)
    assert [e.frame for e in one if e.type == "cut" and e.provisional] == offline_cuts(rec, first)
    assert [e.frame for e in two if e.type == "cut" and e.provisional] == offline_cuts(rec, second)
    assert [e for e in one if e.type == "segments"][-1].final
    finals = [e for e in two if e.type == "segments" and e.final]
    assert finals and finals[-1].end == second.shape[0]
    assert [e.seq for e in live] == sorted({e.seq for e in live})
    assert fetch_since(ep["control"], "r", 0) == live
    sock.close()


def make_log(path, streams=("a", "b", "c"), n=400):
    """A real events.sqlite of ``n`` events per stream, written by :class:`EventLog`."""
    log = EventLog(path, flush_interval=0.001)
    for s in streams:
        for i in range(1, n + 1):
            log.append(s, i, "cut", P.encode(P.Cut(s, i, 0.0, 1.0, i, True), seq=i)[1])
    wait_until(lambda: log.written == n * len(streams), "every event committed", timeout=30)
    return log


def damage(db, page=1):
    """Overwrite the file's pages from ``page`` (0: the header) to its end with garbage."""
    size = db.stat().st_size
    with open(db, "r+b") as fh:
        fh.seek(page * 4096)
        fh.write(b"\xa5" * (size - page * 4096))


def checkpoint_wal(db):
    """Move the WAL's pages into the file (another connection, as any SQLite user may)."""
    con = sqlite3.connect(db)
    con.execute("PRAGMA wal_checkpoint(TRUNCATE)").fetchall()
    con.close()


def test_a_damaged_log_is_moved_aside_at_start(start_daemon, tmp_path, caplog):
    """Damaged while stopped, twice: not a database at all, and damaged pages under a WAL
    that still holds commits. Each time the daemon starts, moves the file aside (warning
    naming both files), publishes an `error` event saying so, and serves a new log."""
    state = tmp_path / "state"
    state.mkdir()
    (state / "events.sqlite").write_bytes(b"this is no database " * 300)
    d, ep = start_daemon()
    aside = list(state.glob("events.corrupt-*.sqlite"))
    assert len(aside) == 1 and aside[0].read_bytes().startswith(b"this is no database")
    warned = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert any(str(state / "events.sqlite") in m and str(aside[0]) in m for m in warned)
    (err,) = [e for e in fetch_since(ep["control"], P.DAEMON_WIDE, 0) if e.type == "error"]
    assert err.reason == "event_log" and str(aside[0]) in err.message
    assert request(ep["control"], "since", stream="a")["ok"]
    d.stop()
    wait_until(lambda: d.state_lock is None, "the state lock released as the shutdown ends")
    # a log with a WAL that holds commits (its writer still open) and damaged pages
    aside[0].unlink()
    log = make_log(tmp_path / "w")
    log._w.execute("PRAGMA wal_autocheckpoint=0")
    for i in range(401, 1401):
        log.append("c", i, "cut", P.encode(P.Cut("c", i, 0.0, 1.0, i, True), seq=i)[1])
    assert log.sync(30)
    for suffix in ("", "-wal"):
        (state / f"events.sqlite{suffix}").unlink(missing_ok=True)
        (state / f"events.sqlite{suffix}").write_bytes(
            (tmp_path / "w" / f"events.sqlite{suffix}").read_bytes()
        )
    log.close()
    assert (state / "events.sqlite-wal").stat().st_size > 0
    damage(state / "events.sqlite")
    d, ep = start_daemon()
    assert len(list(state.glob("events.corrupt-*.sqlite"))) == 1
    for s in ("a", "b", "c"):  # a new log: every stream answers (nothing), none is refused
        reply = request(ep["control"], "since", stream=s)
        assert reply["ok"] and reply["events"] == [], reply


def test_read_errors_name_the_file_and_retention_says_it_once(start_daemon, tmp_path, caplog):
    """Pages damaged under a running daemon: `since` replies name the file (never "bad
    request"), an `error` event says it, the daemon goes on; retention's failures are
    logged once, not every pass."""
    make_log(tmp_path / "state").close()
    d, ep = start_daemon(heartbeat=0.05)
    errors = subscribe(ep["publish"], ep["control"], kind="error")
    checkpoint_wal(d.eventlog.path)
    damage(d.eventlog.path)
    replies = [request(ep["control"], "since", stream=s) for s in ("a", "b", "c")]
    bad = [r for r in replies if not r["ok"]]
    assert bad, replies
    for r in bad:
        assert str(tmp_path / "state" / "events.sqlite") in r["error"]
        assert "bad request" not in r["error"]
    ev = next(e for e in listen(errors, timeout=30) if e.reason == "event_log")
    assert "could not be read" in ev.message and str(d.eventlog.path) in ev.message
    assert request(ep["control"], "ping")["ok"]
    # retention on the damaged file, pass after pass: one ERROR line
    log = EventLog(tmp_path / "r", retention_interval=0.01)
    log.append("s", 1, "cut", b"x" * 100)
    assert log.sync(30)
    checkpoint_wal(log.path)
    damage(log.path)
    wait_until(lambda: log.read_failed >= 5, "5 failed retention passes", timeout=30)
    said = [
        r
        for r in caplog.records
        if "retention failed" in r.getMessage() and str(log.path) in r.getMessage()
    ]
    assert len(said) == 1 and said[0].levelname == "ERROR"
    log.close()


def test_a_lost_tail_shows_in_the_heartbeat(start_daemon, rec):
    """A slow subscriber loses the end of a stream, its `closed` included (another stream's
    burst fills its queue): no later number of the stream ever arrives, but the heartbeats
    carry its last one, so `listen` fetches the rest from the log and ends with every event."""
    d, ep = start_daemon(hwm=1, heartbeat=0.1, gap_events_per_s=1e6)
    ctx = zmq.Context.instance()
    slow = ctx.socket(zmq.SUB)
    slow.setsockopt(zmq.RCVHWM, 1)
    for prefix in (
        P.subscriptions(stream="t") + P.subscriptions(stream="z") + [P.topic("stats", None)]
    ):
        slow.setsockopt(zmq.SUBSCRIBE, prefix)
    slow.connect(ep["publish"])
    pending = handshake(slow, ep["control"])
    sock = ctx.socket(zmq.PUSH)
    sock.connect(ep["ingest"])
    sock.send_multipart(P.encode(announce_of(rec, "t")))
    sock.send_multipart(P.encode(P.Frames("t", 0, 0.0, rec.positions[:1])))
    sock.send_multipart(P.encode(P.Frames("t", 2, 0.0, rec.positions[2:3])))
    holes = []

    def fill(key, first, end):
        holes.append((key, first, end))
        return fetch_since(ep["control"], key, first - 1, upto=end)

    events = listen(slow, stream="t", until_end=True, timeout=20, pending=pending, on_hole=fill)
    head = next(e for e in events if getattr(e, "stream", None) == "t")
    assert head.type == "gap" and head.seq == 1  # received; from here on the SUB waits
    sock.send_multipart(P.encode(announce_of(rec, "z")))
    for a in range(0, 6000, 2):  # 3,000 gap events of another stream fill the queues
        sock.send_multipart(P.encode(P.Frames("z", a, 0.0, rec.positions[:1])))
    for a in range(4, 40, 2):  # the tail of stream t: gaps, then `closed`
        sock.send_multipart(P.encode(P.Frames("t", a, 0.0, rec.positions[a : a + 1])))
    sock.send_multipart(P.encode(P.End("t")))
    sock.close(linger=5000)
    wait_closed(ep, "t")
    logged = fetch_since(ep["control"], "t", 0)
    got = [e for e in (head, *events) if getattr(e, "stream", None) == "t"]
    assert got == logged  # every event, once, in order, the lost tail included
    tail = [h for h in holes if h[0] == "t"][-1]
    assert tail[2] == logged[-1].seq + 1  # the tail, `closed` included: from the heartbeat
    slow.close()
