"""The event log's faults: crashes, re-announced takes, a damaged log, a lost tail, a full
disk. Each against a ``streamseg serve`` subprocess with its state directory (event log and
checkpoints); a live subscriber on the publish socket is compared with the log (``since``).
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import zmq

from streamseg import protocol as P
from streamseg.client import fetch_since, handshake, listen, subscriber
from streamseg.client import takes as split_takes
from streamseg.commands.replay import announce_of

from ._machine import can_mount, fill
from ._served import (
    Sender,
    Served,
    drain,
    missing_from_log,
    named,
    numbered,
    offline_cuts,
    recording,
    row,
)

KILLS = 20


def _numbered_sub(d: Served):
    """A SUB socket for every numbered event of every stream (no heartbeats: it falls
    quiet when the daemon does)."""
    sub = zmq.Context.instance().socket(zmq.SUB)
    for kind in P.EVENT_TYPES:
        if kind != "stats":
            sub.setsockopt(zmq.SUBSCRIBE, f"{kind}/".encode())
    sub.connect(d.ep["publish"])
    return sub


def _wait_checkpoint(d: Served) -> None:
    while not d.request("stats")["totals"].get("checkpoints_written"):
        time.sleep(0.01)


@named("kill -9 x20 during a stream")
def kill9(tmp: Path) -> dict:
    """20 kill -9s at random moments (0.3-2 s after each restart) while a stream runs at
    10,000 frames/s; every numbered event a live subscriber saw must be in the log after."""
    rng = np.random.default_rng(20)
    d = Served(tmp, relabel_interval=1.0, relabel_history=8.0, checkpoint_interval=0.5)
    sub = _numbered_sub(d)
    sender = Sender(d.ep["ingest"], recording())
    seen, restarts = [], []
    try:
        sender.start()
        _wait_checkpoint(d)
        for _ in range(KILLS):
            end = time.monotonic() + rng.uniform(0.3, 2.0)
            while (left := end - time.monotonic()) > 0:
                if sub.poll(int(left * 1000) + 1):
                    seen.append(P.decode(sub.recv_multipart()))
            d.kill()
            seen += drain(sub, 50)  # what was sent before the kill
            restarts.append(d.start())
        sender.stop()
        seen = numbered(seen + drain(sub))
        missing = missing_from_log(d.ep["control"], seen)
        seqs = {}
        dup = sum(seqs.setdefault((e.stream, e.seq), e) != e for e in seen)
    finally:
        sender.stop()
        sub.close(linger=0)
        d.stop()
    return row(
        "kill -9 x20 during a stream",
        f"{len(missing)} of {len(seen)} events seen live missing from the log; {dup} "
        f"numbers seen with two contents",
        f"{KILLS} kills; restart to ping median {statistics.median(restarts):.2f} s",
        not missing and not dup and len(seen) > KILLS,
    )


@named("stream re-announced during its final relabel")
def reannounce(tmp: Path) -> dict:
    """A sender restarts its take (a second announce right behind the first take's 3,000
    frames, 30 s relabel history: the old take's final relabel is running): the old take's
    `closed` must come before any event of the new one, and each take's cuts be its own."""
    rec = recording()
    d = Served(tmp, relabel_interval=1.0, relabel_history=30.0)
    sub = subscriber(d.ep["publish"], stream="r")
    try:
        pending = handshake(sub, d.ep["control"])
        first, second = rec.positions[:3000], rec.positions[1500:4500]
        sock = d.push()
        for pos in (first, second):
            sock.send_multipart(P.encode(announce_of(rec, "r")))
            for a in range(0, pos.shape[0], 50):
                sock.send_multipart(P.encode(P.Frames("r", a, 0.0, pos[a : a + 50])))
        sock.send_multipart(P.encode(P.End("r")))
        live = []
        for ev in listen(sub, stream="r", timeout=60, pending=pending):
            live.append(ev)
            if ev.type == "closed" and ev.reason == "end":
                break
        takes = split_takes(live)
        want = [offline_cuts(rec, first), offline_cuts(rec, second)]
        got = [[e.frame for e in t if e.type == "cut"] for t in takes]
        early = len(set(want[1]) & set(got[0])) if len(takes) > 1 else len(want[1])
        ok = (
            got == want
            and takes[0][-1].reason == "reannounced"
            and fetch_since(d.ep["control"], "r", 0) == live
        )
    finally:
        sub.close(linger=0)
        d.stop()
    return row(
        "stream re-announced during its final relabel",
        f"{early} cuts of the new take published before the old take's closed; each "
        f"take's cuts {'=' if got == want else '!='} its frames' offline cuts",
        f"{len(live)} events, {len(takes)} takes",
        ok,
    )


def _garbage(path: Path, page: int = 1) -> None:
    size = path.stat().st_size
    with open(path, "r+b") as fh:
        fh.seek(page * 4096)
        fh.write(b"\xa5" * max(size - page * 4096, 4096))


def _damaged(tmp: Path, name: str, wal: bool) -> dict:
    d = Served(tmp, checkpoint_interval=0.5)
    rec = recording()
    try:
        sock = d.push()
        sock.send_multipart(P.encode(announce_of(rec, "a")))
        for a in range(0, 2000, 20):
            sock.send_multipart(P.encode(P.Frames("a", a, 0.0, rec.positions[a : a + 20])))
        d.wait_frame("a", 2000)
        before = fetch_since(d.ep["control"], "a", 0)
        db = d.state() / "events.sqlite"
        if wal:
            d.kill()  # the WAL holds the last commits
            assert Path(str(db) + "-wal").stat().st_size > 0
            _garbage(db)
        else:
            d.stop()
            db.write_bytes(b"not a database " * 1000)
        t0 = time.monotonic()
        d.start(log_level="WARNING", stderr=subprocess.PIPE)
        up = time.monotonic() - t0
        aside = sorted(d.state().glob("events.corrupt-*.sqlite"))
        errors = [
            e
            for e in fetch_since(d.ep["control"], P.DAEMON_WIDE, 0)
            if e.type == "error" and e.reason == "event_log"
        ]
        replies = [d.request("since", stream=s) for s in ("a", "b")]
        ok = (
            bool(aside)
            and bool(errors)
            and all(r["ok"] for r in replies)
            and str(aside[0]) in errors[0].message
            and str(db) in errors[0].message
        )
        d.stop()
        said = d.proc.stderr.read()
        named_both = aside and str(db) in said and str(aside[0]) in said
    finally:
        d.stop()
    return row(
        name,
        f"started; the file moved aside ({aside[0].name if aside else 'NOT'}), "
        f"warning naming both files {'yes' if named_both else 'NO'}, `error` event "
        f"{'yes' if errors else 'NO'}; since answers on a new log ({len(before)} old "
        "events stay in the moved file)",
        f"start {up:.2f} s",
        ok and named_both,
    )


@named("events.sqlite damaged while stopped")
def damaged_stopped(tmp: Path) -> dict:
    return _damaged(tmp, "events.sqlite damaged while stopped", wal=False)


@named("events.sqlite damaged, WAL present")
def damaged_wal(tmp: Path) -> dict:
    return _damaged(tmp, "events.sqlite damaged, WAL present", wal=True)


@named("events.sqlite damaged under a running daemon")
def damaged_running(tmp: Path) -> dict:
    """Pages of the log overwritten while the daemon runs: `since` replies name the file,
    an `error` event says it, retention logs it once (not every pass)."""
    rec = recording()
    d = Served(tmp)
    d.stop()
    d.start(log_level="WARNING", stderr=subprocess.PIPE)
    try:
        sock = d.push()
        for s in ("a", "b", "c"):
            sock.send_multipart(P.encode(announce_of(rec, s)))
            for a in range(0, 3000, 20):
                sock.send_multipart(P.encode(P.Frames(s, a, 0.0, rec.positions[a : a + 20])))
            sock.send_multipart(P.encode(P.End(s)))
            d.wait_closed(s)
        errors = subscriber(d.ep["publish"], kind="error")
        handshake(errors, d.ep["control"])
        db = d.state() / "events.sqlite"
        import sqlite3

        con = sqlite3.connect(db)
        con.execute("PRAGMA wal_checkpoint(TRUNCATE)").fetchall()
        con.close()
        _garbage(db)
        replies = [d.request("since", stream=s) for s in ("a", "b", "c")]
        bad = [r["error"] for r in replies if not r["ok"]]
        ev = next((e for e in listen(errors, timeout=10) if e.reason == "event_log"), None)
        alive = d.request("ping")["ok"]
        d.stop()
        said = d.proc.stderr.read()
        spam = said.count("retention failed")
    finally:
        d.stop()
    ok = (
        bad
        and all(str(db) in b and "bad request" not in b for b in bad)
        and ev is not None
        and alive
        and spam <= 1
    )
    return row(
        "events.sqlite damaged under a running daemon",
        f"{len(bad)} of 3 since replies refused, naming the file "
        f"{'yes' if bad and all(str(db) in b for b in bad) else 'NO'}, `error` event "
        f"{'yes' if ev else 'NO'}, serving on",
        f"retention ERROR lines: {spam}",
        ok,
    )


@named("slow subscriber losing a stream's tail")
def lost_tail(tmp: Path) -> dict:
    """A subscriber receives a stream's first event, then stops reading while another
    stream's 3,000 gap events fill its queue and the stream ends: its tail and `closed` are
    lost; the heartbeat's last numbers show the loss and `since` fills it."""
    rec = recording()
    d = Served(tmp, hwm=1, heartbeat=0.1, gap_events_per_s=1e6)
    slow = zmq.Context.instance().socket(zmq.SUB)
    try:
        slow.setsockopt(zmq.RCVHWM, 1)
        for prefix in (
            P.subscriptions(stream="t") + P.subscriptions(stream="z") + [P.topic("stats", None)]
        ):
            slow.setsockopt(zmq.SUBSCRIBE, prefix)
        slow.connect(d.ep["publish"])
        pending = handshake(slow, d.ep["control"])
        sock = d.push()
        sock.send_multipart(P.encode(announce_of(rec, "t")))
        sock.send_multipart(P.encode(P.Frames("t", 0, 0.0, rec.positions[:1])))
        sock.send_multipart(P.encode(P.Frames("t", 2, 0.0, rec.positions[2:3])))
        holes = []

        def fill(key, first, end):
            holes.append((key, first, end))
            return fetch_since(d.ep["control"], key, first - 1, upto=end)

        events = listen(slow, stream="t", until_end=True, timeout=20, pending=pending, on_hole=fill)
        head = next(e for e in events if getattr(e, "stream", None) == "t")
        sock.send_multipart(P.encode(announce_of(rec, "z")))
        for a in range(0, 6000, 2):
            sock.send_multipart(P.encode(P.Frames("z", a, 0.0, rec.positions[:1])))
        for a in range(4, 40, 2):
            sock.send_multipart(P.encode(P.Frames("t", a, 0.0, rec.positions[a : a + 1])))
        sock.send_multipart(P.encode(P.End("t")))
        d.wait_closed("t")
        logged = d.log("t")
        got = [e for e in (head, *events) if getattr(e, "stream", None) == "t"]
        tail = [h for h in holes if h[0] == "t"]
        lost = tail[-1][2] - tail[-1][1] if tail and tail[-1][2] == logged[-1].seq + 1 else 0
    finally:
        slow.close(linger=0)
        d.stop()
    return row(
        "slow subscriber losing a stream's tail",
        f"{lost} events at the tail (closed included) lost live, seen missing from "
        f"the heartbeat and fetched; the subscriber ends with {len(got)} of "
        f"{len(logged)} events",
        f"{len(tail)} holes filled",
        got == logged and lost > 0,
    )


@named("full disk, space freed")
def full_disk(tmp: Path) -> dict:
    """The state directory on a 40 MB tmpfs, filled by a file while a stream runs for 5 s,
    then the file removed for 5 s: events seen live missing from the log, checkpoint rounds
    paused, the checkpoints' WAL size at the end."""
    if not can_mount():
        return row(
            "full disk, space freed", "not run: no tmpfs in a user namespace here", "", False
        )
    d = Served(
        tmp,
        tmpfs_mb=40,
        relabel_interval=1.0,
        relabel_history=8.0,
        checkpoint_interval=0.1,
        heartbeat=0.2,
    )
    sub = _numbered_sub(d)
    sender = Sender(d.ep["ingest"], recording())
    try:
        sender.start()
        _wait_checkpoint(d)
        filler = str(d.state() / "fill")
        fill(filler)
        seen = []
        for hold in (5.0, 5.0):
            end = time.monotonic() + hold
            while (left := end - time.monotonic()) > 0:
                if sub.poll(int(left * 1000) + 1):
                    seen.append(P.decode(sub.recv_multipart()))
            if os.path.exists(filler):
                full = d.request("stats")["totals"]
                os.remove(filler)
        sender.stop()
        seen = numbered(seen + drain(sub))
        missing = missing_from_log(d.ep["control"], seen)
        after = d.request("stats")["totals"]
        wal = os.path.getsize(d.state() / "checkpoints.sqlite-wal")
    finally:
        sender.stop()
        sub.close(linger=0)
        d.stop()
    resumed = after["checkpoints_written"] - full["checkpoints_written"]
    why = full["errors_by_reason"]
    return row(
        "full disk, space freed",
        f"{len(missing)} of {len(seen)} events seen live missing from the log; "
        f"event_log errors {why.get('event_log', 0)}, checkpoint rounds paused/failed "
        f"{why.get('checkpoint', 0)} while full; {resumed} checkpoints after space "
        f"was freed",
        f"checkpoints WAL {wal / 1e6:.2f} MB at the end",
        not missing and not why.get("event_log") and resumed > 0 and wal < 1 << 20,
    )


@named("listen --since 0 after a restart")
def since_after_restart(tmp: Path) -> dict:
    """A stream checkpointed before its first event, kill -9, restart, the stream goes on:
    what `streamseg listen --since 0` says of numbers 1..SEQ_SKIP."""
    rec = recording()
    d = Served(tmp, relabel_interval=0, checkpoint_interval=60.0)
    try:
        sock = d.push()
        sock.send_multipart(P.encode(announce_of(rec, "k")))
        sock.send_multipart(P.encode(P.Frames("k", 0, 0.0, rec.positions[:200])))
        d.wait_frame("k", 200)
        d.request("checkpoint")
        d.kill()
        d.start()
        for a in range(200, rec.n_frames, 100):
            sock.send_multipart(P.encode(P.Frames("k", a, 0.0, rec.positions[a : a + 100])))
        sock.send_multipart(P.encode(P.End("k")))
        logged = d.log("k")
        out = subprocess.run(
            [
                sys.executable,
                "-m",
                "streamseg.cli",
                "listen",
                "--from",
                d.ep["publish"],
                "--control",
                d.ep["control"],
                "--stream",
                "k",
                "--since",
                "0",
                "--until-end",
                "--timeout",
                "30",
            ],
            capture_output=True,
            text=True,
            timeout=120,
        )
    finally:
        d.stop()
    said = out.stderr.strip().splitlines()
    ok = any(f"1..{P.SEQ_SKIP}" in x and "skipped" in x for x in said) and not any(
        "retention" in x for x in said
    )
    return row(
        "listen --since 0 after a restart",
        "; ".join(said) or "nothing said",
        f"{len(logged)} events logged, first {logged[0].seq if logged else '-'}",
        ok,
    )


@named("publish wait, 100 real-time streams")
def publish_wait(tmp: Path) -> dict:
    """100 streams at 120 frames/s (20-frame packets, relabels every 5 s) for 20 s: each
    event's wait between being queued and being published (its commit), and the packet
    latency (arrival to its events queued), from the daemon's `stats`."""
    d = Served(
        tmp, relabel_interval=5.0, relabel_history=60.0, max_streams=200, max_streams_per_client=0
    )
    senders = [Sender(d.ep["ingest"], recording(), f"s{k:03d}", fps=120) for k in range(100)]
    try:
        for s in senders:
            s.start()
        end = time.monotonic() + 20
        while time.monotonic() < end:
            time.sleep(0.5)  # the run's length, not a synchronisation
        tot = d.request("stats")["totals"]
    finally:
        for s in senders:
            s.stop()
        d.stop()
    p50, p99 = tot.get("publish_wait_p50_ms"), tot.get("publish_wait_p99_ms")
    return row(
        "publish wait, 100 real-time streams",
        f"{tot['events']} events, {tot['frames']} frames taken",
        f"commit wait p50 {p50} ms, p99 {p99} ms; packet latency p50 "
        f"{tot['latency_p50_ms']} ms, p99 {tot['latency_p99_ms']} ms",
        p99 is not None and p99 < 100,
    )


CASES = [
    kill9,
    reannounce,
    damaged_stopped,
    damaged_wal,
    damaged_running,
    lost_tail,
    full_disk,
    since_after_restart,
    publish_wait,
]
