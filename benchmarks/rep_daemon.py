"""The real daemon counting an HDM05 routine live: each ``rep`` event with its label and set.

The bd routine of ``rep_routines.py`` (squat x5, deposit, elbow-to-knee x5, grab, hop x5,
throw, kick x5; joined clips, every join abrupt) is replayed over loopback at ``--speed``
(1 = real time: the relabels, every 5 s in a worker thread, then keep up; faster replays get
fewer labels); repetitions and relabelling on. Prints every ``rep`` event (frames, count in
its set, label, set index, delay in seconds), then the true classes.

Run: ``.venv/bin/python benchmarks/rep_daemon.py [--speed 1] [--actor bd]``
"""

from __future__ import annotations

import argparse
import threading
import time

from rep_routines import hdm_routine

from streamseg.client import listen, subscriber
from streamseg.commands.replay import replay
from streamseg.config import DaemonConfig
from streamseg.daemon import Daemon
from streamseg.daemon.pipeline import Algorithms

LOOP = "tcp://127.0.0.1:0"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speed", type=float, default=1.0)
    ap.add_argument("--actor", default="bd")
    args = ap.parse_args(argv)
    rec, truth = hdm_routine(args.actor)
    d = Daemon(DaemonConfig(ingest=LOOP, publish=LOOP, control=LOOP, relabel_interval=5.0,
                            heartbeat=0.2), Algorithms(repetitions=True))
    ep = d.bind()
    t = threading.Thread(target=d.run, daemon=True)
    t.start()
    d.ready.wait(30)
    s = subscriber(ep["publish"], stream="r")
    time.sleep(0.3)  # the subscription reaches the PUB socket before the replay starts
    feed = threading.Thread(target=replay, args=(rec, ep["ingest"]),
                            kwargs=dict(stream="r", speed=args.speed, batch=30))
    feed.start()
    print(f"{'start':>6s} {'end':>6s} {'count':>5s} {'label':>5s} {'set':>3s} {'delay s':>7s} "
          "true class at the middle")
    for e in listen(s, stream="r", until_end=True, timeout=600):
        if e.type == "rep":
            mid = (e.start + e.end) // 2
            cls = next(c for a, b, c, _ in truth if a <= mid < b)
            print(f"{e.start:6d} {e.end:6d} {e.count:5d} {str(e.label):>5s} {e.set_index:3d} "
                  f"{(e.emitted_at - e.end) / rec.fps:7.2f} {cls}")
        elif e.type == "segments":
            print(f"  segments revision {e.revision}: {len(e.segments)} segments, frames "
                  f"{e.start}-{e.end}{' (final)' if e.final else ''}")
    feed.join()
    d.stop()
    t.join(10)
    print("true:", ", ".join(f"{c} {a}-{b} ({n or '-'})" for a, b, c, n in truth))


if __name__ == "__main__":
    main()
