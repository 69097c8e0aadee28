"""Live demo: daemon + replay of CMU 86_01 + listener, then a timeline picture.

Starts the daemon in this process on free loopback ports, replays the bundled recording at a
few times real speed, prints cut and relabel events as they arrive, stops cleanly and draws
provisional cuts, relabelled segments and the human labels on one timeline.
"""

from __future__ import annotations

import argparse
import threading
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[2] / "data" / "cmu86"


def add_arguments(parser) -> None:
    parser.add_argument("--speed", type=float, default=4.0, help="times real time (default 4)")
    parser.add_argument("--plot", metavar="PNG", default="streamseg_demo.png",
                        help="timeline picture to write (default streamseg_demo.png)")
    parser.add_argument("--batch", type=int, default=4, help="frames per packet (default 4)")
    parser.add_argument("--file", default=str(DATA / "86_01.amc.gz"), help=argparse.SUPPRESS)
    parser.add_argument("--skeleton", default=str(DATA / "86.asf"), help=argparse.SUPPRESS)
    parser.add_argument("--labels", default=str(DATA / "labels_86_01.csv"), help=argparse.SUPPRESS)


def run(args) -> int:
    from streamseg.commands.listen import format_event, listen, subscriber
    from streamseg.commands.replay import replay
    from streamseg.config import DaemonConfig
    from streamseg.daemon import Daemon
    from streamseg.io import read

    rec = read(args.file, skeleton=args.skeleton)
    stream = "86_01"
    loop = "tcp://127.0.0.1:0"
    daemon = Daemon(DaemonConfig(ingest=loop, publish=loop, control=loop, relabel_interval=3.0,
                                 relabel_history=12.0, heartbeat=0))
    ep = daemon.bind()
    server = threading.Thread(target=daemon.run, name="streamseg-daemon", daemon=True)
    server.start()
    print(f"daemon: ingest {ep['ingest']}  publish {ep['publish']}  control {ep['control']}")
    print("warming kernels ...", flush=True)
    daemon.ready.wait()
    sub = subscriber(ep["publish"], stream=stream)
    time.sleep(0.2)
    events = []
    t0 = time.monotonic()

    def show():
        for ev in listen(sub, stream=stream, until_end=True):
            events.append(ev)
            if ev.type in ("cut", "segments", "closed", "error", "gap"):
                print(f"{time.monotonic() - t0:6.2f}s  {format_event(ev)}", flush=True)

    listener = threading.Thread(target=show, name="streamseg-listen", daemon=True)
    listener.start()
    print(f"replaying {Path(args.file).name}: {rec.n_frames} frames at {rec.fps:g} Hz, "
          f"{args.speed:g}x real time ({rec.n_frames / rec.fps / max(args.speed, 1e-9):.1f} s)",
          flush=True)
    try:
        replay(rec, ep["ingest"], stream=stream, speed=args.speed, batch=args.batch)
        listener.join(60)
    except KeyboardInterrupt:
        print("interrupted: stopping the daemon")
    finally:
        daemon.stop()
        server.join(30)
        sub.close()
    print(f"daemon stopped; {sum(e.type == 'cut' for e in events)} cuts, "
          f"{sum(e.type == 'segments' for e in events)} relabels")
    if args.plot:
        try:
            timeline(events, rec, args.labels, stream, args.plot)
            print(f"wrote {args.plot}")
        except ImportError:
            print("matplotlib is not installed (pip install 'streamseg[plot]'): no picture")
    return 0


def timeline(events, rec, labels_csv, sequence, path) -> None:
    """Draw human labels, the newest relabel of every frame, and the provisional cuts."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from streamseg.labels import read_labels

    fps, n = rec.fps, rec.n_frames
    human = read_labels(labels_csv, sequence)
    relab = np.full(n, -1)
    for ev in events:  # later revisions overwrite what they cover
        if ev.type == "segments":
            for a, b, lab in ev.segments:
                relab[a:min(b, n)] = lab
    cuts = [ev for ev in events if ev.type == "cut"]
    fig, ax = plt.subplots(figsize=(12, 3.2))
    cmap = plt.get_cmap("tab10")
    names = sorted({s.label for s in human})
    for s in human:
        ax.broken_barh([(s.start / fps, (s.end - s.start) / fps)], (2, 0.8),
                       color=cmap(names.index(s.label)), alpha=0.8)
        ax.text((s.start + s.end) / 2 / fps, 2.4, s.label, ha="center", va="center", fontsize=8)
        if s.end < n:
            ax.axvspan(s.lo / fps, s.hi / fps, ymin=0.66, ymax=0.92, color="k", alpha=0.12)
    change = np.flatnonzero(np.diff(relab)) + 1
    bounds = np.concatenate([[0], change, [n]])
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        if relab[a] >= 0:
            ax.broken_barh([(a / fps, (b - a) / fps)], (1, 0.8), color=cmap(5 + relab[a] % 5),
                           alpha=0.8)
    for c in cuts:
        ax.plot([c.frame / fps] * 2, [0.05, 0.85], color="crimson", lw=1.5)
        ax.plot([c.emitted_at / fps], [0.1], marker=">", color="crimson", ms=4)
    ax.set_yticks([0.45, 1.4, 2.4])
    ax.set_yticklabels(["provisional cuts\n(> = emitted)", "relabelled (ACA)", "human labels"])
    ax.set_xlim(0, n / fps)
    ax.set_ylim(0, 3)
    ax.set_xlabel("time (s)")
    ax.set_title(f"streamseg demo: CMU {sequence}, live")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
