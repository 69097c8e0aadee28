"""The checkpoint writer's pause after each packed array (``checkpoint_store.BREATHE``): packet
latency and relabels at a stream count near the machine's capacity, durability off, on with
the pause, on without it.

Run: ``.venv/bin/python benchmarks/checkpoint_pause.py [--streams 250] [--seconds 30]
[--repeats 4]``

Each run is one ``daemon_throughput.capacity_run`` (real-time 120 Hz streams of CMU 86_01,
4 frames per packet, relabelling on, the last ``seconds - 2.5`` s measured); the three modes
run interleaved, the order alternating, so slow phases of the machine hit them alike. Prints
each run and the medians.
"""

from __future__ import annotations

import argparse
import statistics

import daemon_throughput as bench
import numpy as np

from streamseg import protocol as P
from streamseg.commands.replay import announce_of
from streamseg.daemon import checkpoint_store

MODES = {"off": None, "pause": checkpoint_store.BREATHE, "no pause": 0.0}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--streams", type=int, default=250)
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--repeats", type=int, default=4)
    args = ap.parse_args()
    rec, batch = bench.load(), 4
    reps = int(np.ceil((args.seconds + 2) * rec.fps / rec.n_frames))
    pos = np.concatenate([rec.positions] * reps)
    ph = bench.ID.decode()
    tmpl = [P.encode(P.Frames(ph, a, 0.0, pos[a:a + batch]))[1]
            for a in range(0, pos.shape[0], batch)]
    announce = P.encode(announce_of(rec, ph))[1]
    print(f"{args.streams} real-time streams, {args.seconds:g} s per run, {args.repeats} "
          "interleaved runs per mode")
    print(f"{'run':>4} {'mode':>9} {'taken f/s':>10} {'p50 ms':>8} {'p99 ms':>8} "
          f"{'relabels/s':>10} {'durability CPU %':>16}")
    runs = {m: [] for m in MODES}
    for k in range(args.repeats):
        for mode in (list(MODES) if k % 2 == 0 else list(MODES)[::-1]):
            pause = MODES[mode]
            if pause is not None:
                checkpoint_store.BREATHE = pause
            r = bench.capacity_run(rec, tmpl, announce, args.streams, batch, args.seconds,
                                   pause is not None, args.streams + 10)
            runs[mode].append(r)
            print(f"{k:>4} {mode:>9} {r[0]:>10,.0f} {r[1] * 1e3:>8.2f} {r[2] * 1e3:>8.2f} "
                  f"{r[3]:>10.2f} {100 * r[4]:>16.1f}", flush=True)
    for mode, rs in runs.items():
        med = [statistics.median(r[i] for r in rs) for i in range(5)]
        print(f"{'med':>4} {mode:>9} {med[0]:>10,.0f} {med[1] * 1e3:>8.2f} "
              f"{med[2] * 1e3:>8.2f} {med[3]:>10.2f} {100 * med[4]:>16.1f}")


if __name__ == "__main__":
    main()
