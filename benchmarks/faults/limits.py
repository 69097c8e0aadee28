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
from ._served import MID, Served, base_cuts, drain, holes, named, recording, row, send_good

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
            sock.send_multipart(P.encode(P.Frames("big", a, 0.0,
                                                  rec.positions[(a + idx) % rec.n_frames])))
        sent = time.monotonic() - t0
        total = BIG_PACKETS * BIG_FRAMES
        d.wait_frame("big", total, timeout=1800)
        took = time.monotonic() - t0
        peak = d.rss_peak_mb()
        tot = d.request("stats")["totals"]
        sock.close()
    finally:
        d.stop()
    result = (f"{tot['frames']:,} frames taken of {total:,}, errors "
              f"{tot['errors_by_reason'] or 'none'}; ZeroMQ's bound lowered to "
              f"{tot['ingest_hwm']} packets")
    figure = (f"RSS peak {peak:.0f} MB; latency p50 {tot['latency_p50_ms']:.0f} ms, p99 "
              f"{tot['latency_p99_ms']:.0f} ms; all processed in {took:.1f} s "
              f"({BIG_PACKETS * BIG_FRAMES * 744 / took / 1e6:.0f} MB/s; sender done after "
              f"{sent:.1f} s)")
    return row("1,000 valid 10 MB packets", result, figure,
               peak < 1024 and tot["frames"] == total)


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
    lost = holes(events) + len(set(base_cuts()) - set(cuts)) + \
        sum((e.seq, e) not in logged for e in seen)
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
    result = (f"{', '.join(refused) or 'nothing'} refused, end and re-announce refused "
              f"({owner} owner errors); daemon {'running' if alive else 'STOPPED'}; {lost} "
              f"events lost, cuts {'=' if equal else '!='} no-fault")
    return row("another local user, no CURVE", result, out.get("raised") or
               f"the stranger's uid {out.get('uid')}",
               len(refused) == 2 and owner == 2 and alive and lost == 0 and equal)


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
    result = (f"{tot['streams'] - 1} flood streams open (quota 1000 per connection), "
              f"{tot['errors_by_reason'].get('quota', 0)} refused (quota); a stream from "
              f"another process was accepted")
    return row("10,000 announces, no CURVE", result, f"flood to the late stream's 200th "
               f"frame {took:.1f} s", tot["streams"] == 1001)


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
    return row("tcp://[::1]", f"served on {d.ep['ingest']}; cuts "
               f"{'=' if cuts == list(base_cuts()) else '!='} no-fault",
               f"{len(events)} events logged", cuts == list(base_cuts()))



LEAVING = 200  # senders
LEAVING_FRAMES = 100  # x 31 joints x 3 x 8 bytes = 74 kB: large for the default budget


@named("200 senders of large packets that leave")
def large_senders_leave(tmp: Path) -> dict:
    """200 senders one after the other, each a connection of its own as `streamseg replay`
    makes: a take of 500 frames in packets of 100 frames (74 kB, over the default budget's
    large-message size, so the daemon lowers ZeroMQ's bound and raises it again), its end,
    and the connection closed at once. Passes when the daemon is still running and took
    every frame. Known to fail (open): libzmq 4.3.5 sends a new RCVHWM to the pipes of the
    socket's connections, an ending one's peer may already be freed, and the daemon dies of
    SIGSEGV in a ZeroMQ I/O thread."""
    rec = recording()
    d = Served(tmp, relabel_interval=0.0, heartbeat=0.0)
    died, k = None, 0
    try:
        for k in range(LEAVING):
            s = d.push()
            s.send_multipart(P.encode(announce_of(rec, f"s{k}")))
            for a in range(0, 5 * LEAVING_FRAMES, LEAVING_FRAMES):
                s.send_multipart(P.encode(P.Frames(f"s{k}", a, 0.0,
                                                   rec.positions[a:a + LEAVING_FRAMES])))
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
        return row("200 senders of large packets that leave",
                   f"the daemon died (exit {died}) after sender {k + 1} of {LEAVING}",
                   "ZeroMQ's bound changed on an open socket (libzmq 4.3.5)", False)
    ok = tot is not None and tot["frames"] == total
    return row("200 senders of large packets that leave",
               f"{tot['frames'] if tot else '?'} frames taken of {total}",
               "the daemon still runs", ok)

CASES = [big_packets, stranger, local_announce_flood, ipv6_loopback, large_senders_leave]
