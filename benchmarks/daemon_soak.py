"""Soak: millions of frames through one daemon at full speed; resident memory must stay flat.

Run: ``.venv/bin/python benchmarks/daemon_soak.py [--frames 2000000] [--streams 10]
[--rounds 4] [--batch 60]``

A separate sender process pushes ``--rounds`` rounds of ``--streams`` concurrent streams (CMU
86_01 cycled, each stream starting at a different offset, packets of the streams interleaved),
announcing and ending every stream, as fast as the daemon takes them (PUSH backpressure).
Relabelling is on (every 5 s over 20 s). The daemon runs in this process; its RSS is read
from /proc at start (kernels warm, no stream yet), at every quarter of the frames, and at the
end (all streams closed). Flat means the end is within a few MB of the middle: per-stream
buffers are bounded and closed streams free theirs.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import threading
import time
from pathlib import Path

import numpy as np
import zmq

from streamseg import protocol as P
from streamseg.commands.replay import announce_of
from streamseg.config import DaemonConfig
from streamseg.daemon import Daemon
from streamseg.io import read

DATA = Path(__file__).resolve().parents[1] / "data" / "cmu86"


def rss_mb() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def sender(endpoint, per_stream, n_streams, rounds, batch, go):
    rec = read(DATA / "86_01.amc.gz", skeleton=DATA / "86.asf")
    ctx = zmq.Context()
    s = ctx.socket(zmq.PUSH)
    s.setsockopt(zmq.LINGER, -1)
    s.connect(endpoint)
    go.wait()
    for r in range(rounds):
        names = [f"soak{r:03d}-{k:03d}" for k in range(n_streams)]
        for name in names:
            s.send_multipart(P.encode(announce_of(rec, name)))
        offsets = [(k * 997) % rec.n_frames for k in range(n_streams)]
        for a in range(0, per_stream, batch):
            m = min(batch, per_stream - a)
            for name, off in zip(names, offsets, strict=True):
                idx = (off + a + np.arange(m)) % rec.n_frames
                s.send_multipart(P.encode(P.Frames(name, a, 0.0, rec.positions[idx])))
        for name in names:
            s.send_multipart(P.encode(P.End(name)))
    s.close()
    ctx.term()


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=2_000_000)
    ap.add_argument("--streams", type=int, default=10)
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--batch", type=int, default=60)
    args = ap.parse_args()
    per_stream = -(-args.frames // (args.streams * args.rounds))
    total = per_stream * args.streams * args.rounds
    loop = "tcp://127.0.0.1:0"
    d = Daemon(DaemonConfig(ingest=loop, publish=loop, control="", heartbeat=1.0))
    ep = d.bind()
    t = threading.Thread(target=d.run, daemon=True)
    t.start()
    d.ready.wait()
    ctx = mp.get_context("spawn")
    go = ctx.Event()
    p = ctx.Process(target=sender, args=(ep["ingest"], per_stream, args.streams, args.rounds,
                                         args.batch, go))
    p.start()
    time.sleep(2.0)
    rows = [("start", 0, 0.0, rss_mb(), 0)]
    t0 = time.perf_counter()
    go.set()
    marks = [total // 4, total // 2, 3 * total // 4]
    peak = rows[0][3]
    while d.n_frames < total or d.streams or d.closing:
        time.sleep(0.05)
        peak = max(peak, rss_mb())
        if marks and d.n_frames >= marks[0]:
            rows.append((f"{len(rows) * 25}%", d.n_frames, time.perf_counter() - t0, rss_mb(),
                         len(d.streams)))
            marks.pop(0)
        if time.perf_counter() - t0 > 1800:
            raise RuntimeError(f"soak did not finish: {d._totals()}")
    rows.append(("end", d.n_frames, time.perf_counter() - t0, rss_mb(), len(d.streams)))
    p.join()
    totals = d._totals()
    d.stop()
    t.join()
    print(f"\nsoak: {total:,} frames = {args.rounds} rounds x {args.streams} streams x "
          f"{per_stream:,} frames, {args.batch} frames/packet, relabel every 5 s over 20 s")
    print(f"{'point':>6} {'frames':>10} {'seconds':>8} {'frames/s':>10} {'RSS MB':>8} "
          f"{'open streams':>12}")
    for name, n, sec, rss, open_ in rows:
        rate = f"{n / sec:,.0f}" if sec else "-"
        print(f"{name:>6} {n:>10,} {sec:>8.1f} {rate:>10} {rss:>8.1f} {open_:>12}")
    print(f"peak RSS {peak:.1f} MB; end - 50%: {rows[-1][3] - rows[2][3]:+.1f} MB; "
          f"relabels {totals.get('relabels', 0)}, events {totals.get('events', 0)}, "
          f"errors {totals['errors']}, streams opened {totals.get('streams_opened', 0)}")


if __name__ == "__main__":
    main()
