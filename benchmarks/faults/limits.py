"""Limits and strangers: memory under a flood of large valid packets, the per-connection
quota, another local user without the control token, stream ownership, IPv6 loopback.

Each case runs a `streamseg serve` subprocess (helpers in :mod:`faults._served`).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import zmq

from streamseg import protocol as P
from streamseg.client import request
from streamseg.commands.replay import announce_of, replay

from ._machine import has_ipv6_loopback, in_child
from ._served import DATA, MID, Served, base_cuts, drain, holes, named, recording, row, send_good

LOOP = "tcp://127.0.0.1:0"  # another user cannot reach ipc files in this user's temp folder

BIG_FRAMES = 14_094  # x 31 joints x 3 x 8 bytes = 10,485,936 bytes: a 10 MB packet
BIG_PACKETS = 1000


@named("1,000 valid 10 MB packets")
def big_packets(tmp: Path) -> dict:
    """One sender pushes 1,000 valid packets of 14,094 frames (10 MB each; max_packet_frames
    raised to take them) of CMU 86_01 as fast as the daemon lets it; the daemon's RSS peak
    (VmHWM) over the whole run, its packet latency (arrival to events published) and the
    time until the last frame was processed. Passes when the peak stays under 1 GB."""
    rec = recording()
    d = Served(tmp, max_packet_frames=BIG_FRAMES, relabel_interval=0.0)
    try:
        sock = d.push()
        sock.send_multipart(P.encode(announce_of(rec, "big")))
        idx = np.arange(BIG_FRAMES)
        t0 = time.monotonic()
        for k in range(BIG_PACKETS):
            a = k * BIG_FRAMES
            sock.send_multipart(
                P.encode(P.Frames("big", a, 0.0, rec.positions[(a + idx) % rec.n_frames]))
            )
        sent = time.monotonic() - t0
        total = BIG_PACKETS * BIG_FRAMES
        d.wait_frame("big", total, timeout=1800)
        took = time.monotonic() - t0
        peak = d.rss_peak_mb()
        tot = d.request("stats")["totals"]
        sock.close()
    finally:
        d.stop()
    result = (
        f"{tot['frames']:,} frames taken of {total:,}, errors "
        f"{tot['errors_by_reason'] or 'none'}; ZeroMQ's bound {tot['ingest_hwm']} "
        f"packets per connection (fixed), the receiver's queue at most "
        f"{tot['ingest_peak_bytes'] / 1e6:.0f} MB"
    )
    figure = (
        f"RSS peak {peak:.0f} MB; latency p50 {tot['latency_p50_ms']:.0f} ms, p99 "
        f"{tot['latency_p99_ms']:.0f} ms; all processed in {took:.1f} s "
        f"({BIG_PACKETS * BIG_FRAMES * 744 / took / 1e6:.0f} MB/s; sender done after "
        f"{sent:.1f} s)"
    )
    return row("1,000 valid 10 MB packets", result, figure, peak < 1024 and tot["frames"] == total)


def _errors(d, reason):
    return d.request("stats")["totals"]["errors_by_reason"].get(reason, 0)


def _finish_good(d, sock, live) -> tuple:
    """The good stream's rest and end; (events lost, cuts = no-fault) from the log."""
    rec = recording()
    send_good(sock, rec, MID, rec.n_frames)
    sock.send_multipart(P.encode(P.End("good")))
    d.wait_closed("good")
    events = d.log("good")
    seen = drain(live)
    logged = {(e.seq, e) for e in events}
    cuts = [e.frame for e in events if e.type == "cut"]
    lost = (
        holes(events)
        + len(set(base_cuts()) - set(cuts))
        + sum((e.seq, e) not in logged for e in seen)
    )
    return lost, cuts == list(base_cuts()), events


@named("another local user, no CURVE")
def stranger(tmp: Path) -> dict:
    """A process of another uid (nobody; the runner is root) sends shutdown and checkpoint on
    the control socket, then end and a re-announce of the good stream on the ingest socket."""
    from streamseg.client import subscriber

    rec = recording()
    d = Served(tmp, endpoint=LOOP)
    try:
        sock = d.push()
        live = subscriber(d.ep["publish"], stream="good")
        sock.send_multipart(P.encode(announce_of(rec, "good")))
        send_good(sock, rec, 0, MID)
        d.wait_frame("good", MID)
        ep = dict(d.ep)

        def act(ctx):
            out = {"uid": os.geteuid()}
            for op in ("shutdown", "checkpoint"):
                out[op] = request(ep["control"], op, ctx=ctx, timeout=60)
            push = ctx.socket(zmq.PUSH)
            push.connect(ep["ingest"])
            push.send_multipart(P.encode(P.End("good")))
            push.send_multipart(P.encode(announce_of(rec, "good")))
            push.close(linger=20000)
            ctx.term()
            return out

        out = in_child(act, other_user=True)
        t0 = time.monotonic()
        while _errors(d, "owner") < 2 and time.monotonic() - t0 < 60:
            time.sleep(0.01)  # both ingest messages taken
        owner = _errors(d, "owner")
        alive = d.proc.poll() is None
        lost, equal, _ = _finish_good(d, sock, live)
    finally:
        d.stop()
    refused = [op for op in ("shutdown", "checkpoint") if not out.get(op, {}).get("ok", True)]
    result = (
        f"{', '.join(refused) or 'nothing'} refused, end and re-announce refused "
        f"({owner} owner errors); daemon {'running' if alive else 'STOPPED'}; {lost} "
        f"events lost, cuts {'=' if equal else '!='} no-fault"
    )
    return row(
        "another local user, no CURVE",
        result,
        out.get("raised") or f"the stranger's uid {out.get('uid')}",
        len(refused) == 2 and owner == 2 and alive and lost == 0 and equal,
    )


@named("10,000 announces, no CURVE")
def local_announce_flood(tmp: Path) -> dict:
    """One local process (one connection) announces 10,000 streams with the default quota
    (1,000 per client, 2,000 in all); then a stream from this process."""
    rec = recording()
    d = Served(tmp)
    try:
        ep = dict(d.ep)
        msgs = [P.encode(announce_of(rec, f"flood{k:05d}")) for k in range(10000)]

        def flood(ctx):
            push = ctx.socket(zmq.PUSH)
            push.connect(ep["ingest"])
            for m in msgs:
                push.send_multipart(m)
            push.close(linger=60000)
            ctx.term()
            return {}

        t0 = time.monotonic()
        in_child(flood, other_user=False)
        while _errors(d, "quota") < 9000:
            time.sleep(0.05)  # the flood has been taken
        late = d.push()
        late.send_multipart(P.encode(announce_of(rec, "late")))
        send_good(late, rec, 0, 200, stream="late")
        d.wait_frame("late", 200, timeout=120)
        took = time.monotonic() - t0
        tot = d.request("stats")["totals"]
        late.close()
    finally:
        d.stop()
    result = (
        f"{tot['streams'] - 1} flood streams open (quota 1000 per connection), "
        f"{tot['errors_by_reason'].get('quota', 0)} refused (quota); a stream from "
        f"another process was accepted"
    )
    return row(
        "10,000 announces, no CURVE",
        result,
        f"flood to the late stream's 200th frame {took:.1f} s",
        tot["streams"] == 1001,
    )


@named("tcp://[::1]")
def ipv6_loopback(tmp: Path) -> dict:
    """The daemon on IPv6 loopback: the good stream replayed and cut there."""
    if not has_ipv6_loopback():
        return row("tcp://[::1]", "this machine has no ::1", "", True)
    rec = recording()
    d = Served(tmp, endpoint="tcp://[::1]:0")
    try:
        replay(rec, d.ep["ingest"], stream="good", speed=0, batch=20, wait=60)
        events = d.log("good")
    finally:
        d.stop()
    cuts = [e.frame for e in events if e.type == "cut"]
    return row(
        "tcp://[::1]",
        f"served on {d.ep['ingest']}; cuts {'=' if cuts == list(base_cuts()) else '!='} no-fault",
        f"{len(events)} events logged",
        cuts == list(base_cuts()),
    )


LEAVING = 200  # senders
LEAVING_FRAMES = 100  # x 31 joints x 3 x 8 bytes = 74 kB: large for the default budget


@named("200 senders of large packets that leave")
def large_senders_leave(tmp: Path) -> dict:
    """200 senders one after the other, each a connection of its own as `streamseg replay`
    makes: a take of 500 frames in packets of 100 frames (74 kB), its end, and the connection
    closed at once. Passes when the daemon is still running and took every frame. The
    daemon died here (SIGSEGV in a ZeroMQ I/O thread) while it changed RCVHWM on the open
    socket: libzmq 4.3.5 sends a new bound to the pipes of the socket's connections, and an
    ending one's peer may already be freed (docs/decisions.md, Ingest memory)."""
    rec = recording()
    d = Served(tmp, relabel_interval=0.0, heartbeat=0.0)
    died, k = None, 0
    try:
        for k in range(LEAVING):
            s = d.push()
            s.send_multipart(P.encode(announce_of(rec, f"s{k}")))
            for a in range(0, 5 * LEAVING_FRAMES, LEAVING_FRAMES):
                s.send_multipart(
                    P.encode(P.Frames(f"s{k}", a, 0.0, rec.positions[a : a + LEAVING_FRAMES]))
                )
            s.send_multipart(P.encode(P.End(f"s{k}")))
            s.close()  # its linger delivers the packets, then the connection ends
            if d.proc.poll() is not None:
                died = d.proc.returncode
                break
        total, tot, t0 = LEAVING * 5 * LEAVING_FRAMES, None, time.monotonic()
        while died is None and time.monotonic() - t0 < 120:  # until every frame is taken
            try:
                tot = d.request("stats", timeout=2)["totals"]
            except TimeoutError:
                pass
            died = d.proc.poll()
            if tot is not None and tot["frames"] == total:
                break
            time.sleep(0.05)
    finally:
        d.stop()
    if died is not None:
        return row(
            "200 senders of large packets that leave",
            f"the daemon died (exit {died}) after sender {k + 1} of {LEAVING}",
            "a daemon that dies loses every open stream's live state",
            False,
        )
    ok = tot is not None and tot["frames"] == total
    return row(
        "200 senders of large packets that leave",
        f"{tot['frames'] if tot else '?'} frames taken of {total}",
        "the daemon still runs",
        ok,
    )


CASES = [big_packets, stranger, local_announce_flood, ipv6_loopback, large_senders_leave]


REPLAYS = 30


@named("30 replays at --speed 0 --batch 120")
def replays_in_a_row(tmp: Path) -> dict:
    """`streamseg replay` of CMU 86_01 at --speed 0 --batch 120 (89 kB packets), a new
    stream id each time, 30 times one after the other into one `streamseg serve` with its
    defaults on TCP loopback, as a user would. Passes when the daemon is alive after each and
    took every frame of all of them."""
    import subprocess
    import sys

    rec = recording()
    d = Served(tmp, endpoint=LOOP)
    died, k = None, 0
    try:
        for k in range(REPLAYS):
            subprocess.run(
                [
                    sys.executable,
                    "-c",
                    "import sys; from streamseg.cli import main; sys.exit(main(sys.argv[1:]))",
                    "replay",
                    str(DATA / "86_01.amc.gz"),
                    "--skeleton",
                    str(DATA / "86.asf"),
                    "--to",
                    d.ep["ingest"],
                    "--speed",
                    "0",
                    "--batch",
                    "120",
                    "--stream",
                    f"r{k}",
                ],
                check=True,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
            if d.proc.poll() is not None:
                died = d.proc.returncode
                break
        if died is None:  # each replay ended its stream: wait until the last is closed
            d.wait_closed(f"r{REPLAYS - 1}")
            tot = d.request("stats")["totals"]
    finally:
        d.stop()
    if died is not None:
        return row(
            "30 replays at --speed 0 --batch 120",
            f"the daemon died (exit {died}) during replay {k + 1} of {REPLAYS}",
            "a daemon that dies loses every open stream's live state",
            False,
        )
    total = REPLAYS * rec.n_frames
    return row(
        "30 replays at --speed 0 --batch 120",
        f"{tot['frames']:,} frames taken of {total:,}",
        "the daemon still runs",
        tot["frames"] == total,
    )


LARGE_SENDERS, LARGE_PACKETS, LARGE_FRAMES = 8, 30, 12_000


@named("8 senders of 8.9 MB packets at once")
def large_senders_at_once(tmp: Path) -> dict:
    """8 connections at once, each 30 packets of 12,000 frames of 86_01 in float64 (8.9 MB,
    the largest the default max_packet_frames allows for 31 joints), sent as fast as the
    daemon lets them, default ``ingest_bytes`` (256 MiB). The daemon's resident memory
    growth over idle (VmHWM after, VmRSS before) against the budget. Passes when every frame
    is taken and the growth is at most 1.25 x ``ingest_bytes``."""
    rec = recording()
    budget = 256 << 20
    d = Served(tmp, endpoint=LOOP, relabel_interval=0.0)
    try:
        idx = np.arange(LARGE_FRAMES)
        socks = []
        for k in range(LARGE_SENDERS):
            s = d.push()
            s.setsockopt(zmq.SNDHWM, 2)  # this process holds few packets itself
            s.send_multipart(P.encode(announce_of(rec, f"big{k}")))
            socks.append(s)
        for k in range(LARGE_SENDERS):
            d.wait_frame(f"big{k}", 0)
        base = _rss_mb(d.proc.pid, "VmRSS")
        with open(f"/proc/{d.proc.pid}/clear_refs", "w") as fh:
            fh.write("5")  # VmHWM := VmRSS: the peak from here on
        t0 = time.monotonic()
        for j in range(LARGE_PACKETS):
            a = j * LARGE_FRAMES
            pos = rec.positions[(a + idx) % rec.n_frames].astype(np.float64)
            for k, s in enumerate(socks):
                s.send_multipart(P.encode(P.Frames(f"big{k}", a, 0.0, pos)))
        total = LARGE_PACKETS * LARGE_FRAMES
        for k in range(LARGE_SENDERS):
            d.wait_frame(f"big{k}", total, timeout=600)
        took = time.monotonic() - t0
        growth = d.rss_peak_mb() - base
        tot = d.request("stats")["totals"]
        for s in socks:
            s.close(linger=0)
    finally:
        d.stop()
    frames = LARGE_SENDERS * total
    ok = tot["frames"] == frames and growth <= 1.25 * budget / (1 << 20)
    return row(
        "8 senders of 8.9 MB packets at once",
        f"{tot['frames']:,} frames taken of {frames:,}; errors {tot['errors_by_reason'] or 'none'}",
        f"RSS growth {growth:.0f} MiB (1.25 x ingest_bytes = {1.25 * budget / (1 << 20):.0f}"
        f" MiB); receiver queue peak {tot['ingest_peak_bytes'] / (1 << 20):.0f} MiB; "
        f"ZeroMQ bound {tot['ingest_hwm']} per connection; {took:.1f} s",
        ok,
    )


def _rss_mb(pid: int, key: str) -> float:
    with open(f"/proc/{pid}/status") as fh:
        return next(int(line.split()[1]) / 1024 for line in fh if line.startswith(key))


CASES += [replays_in_a_row, large_senders_at_once]
