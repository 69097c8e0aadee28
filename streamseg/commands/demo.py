"""Live demo: daemon + replay of CMU 86_01 + listener, then a timeline picture.

Starts the daemon in this process on free loopback ports, replays the bundled recording at a
few times real speed, prints cut and relabel events as they arrive, stops cleanly and draws
provisional cuts, relabelled segments and the human labels on one timeline. With the ``view``
extra installed it also serves the live web page (``streamseg view``) and prints its address;
on a terminal the page stays up after the replay until Enter or Ctrl-C.
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[2] / "data" / "cmu86"


def add_arguments(parser) -> None:
    parser.add_argument("--speed", type=float, default=4.0, help="times real time (default 4)")
    parser.add_argument(
        "--plot",
        metavar="PNG",
        default="streamseg_demo.png",
        help="timeline picture to write (default streamseg_demo.png)",
    )
    parser.add_argument("--batch", type=int, default=4, help="frames per packet (default 4)")
    parser.add_argument(
        "--http",
        default="127.0.0.1:8765",
        metavar="HOST:PORT",
        help="address of the live page (default 127.0.0.1:8765, another free "
        "port if that one is taken)",
    )
    parser.add_argument(
        "--no-view",
        dest="view",
        action="store_false",
        help="no live page, even with the view extra installed",
    )
    parser.add_argument("--file", default=str(DATA / "86_01.amc.gz"), help=argparse.SUPPRESS)
    parser.add_argument("--skeleton", default=str(DATA / "86.asf"), help=argparse.SUPPRESS)
    parser.add_argument("--labels", default=str(DATA / "labels_86_01.csv"), help=argparse.SUPPRESS)


def run(args) -> int:
    from streamseg.client import listen, subscribe
    from streamseg.commands.args import check_plot
    from streamseg.commands.listen import format_event
    from streamseg.commands.replay import replay
    from streamseg.config import DaemonConfig
    from streamseg.daemon import Daemon
    from streamseg.io import read

    check_plot(args.plot, need_matplotlib=False)  # before the run, not after it
    rec = read(args.file, skeleton=args.skeleton)
    stream = "86_01"
    loop = "tcp://127.0.0.1:0"
    daemon = Daemon(DaemonConfig(ingest=loop, publish=loop, control=loop, heartbeat=0))
    ep = daemon.bind()
    server = threading.Thread(target=daemon.run, name="streamseg-daemon", daemon=True)
    server.start()
    print(f"daemon: ingest {ep['ingest']}  publish {ep['publish']}  control {ep['control']}")
    print("warming kernels ...", flush=True)
    daemon.ready.wait()
    view = _start_view(args, ep) if args.view else None
    sub = subscribe(ep["publish"], ep["control"], stream=stream)
    events = []
    t0 = time.monotonic()

    def show():
        for ev in listen(sub, stream=stream, until_end=True):
            events.append(ev)
            if ev.type in ("cut", "segments", "closed", "error", "gap"):
                print(f"{time.monotonic() - t0:6.2f}s  {format_event(ev)}", flush=True)

    listener = threading.Thread(target=show, name="streamseg-listen", daemon=True)
    listener.start()
    print(
        f"replaying {Path(args.file).name}: {rec.n_frames} frames at {rec.fps:g} Hz, "
        + (
            f"{args.speed:g}x real time ({rec.n_frames / rec.fps / args.speed:.1f} s)"
            if args.speed > 0
            else "as fast as the daemon takes it"
        ),
        flush=True,
    )
    try:
        replay(
            rec,
            ep["ingest"],
            stream=stream,
            speed=args.speed,
            batch=args.batch,
            labels=args.labels,
            labels_sequence=stream,
        )
        listener.join(60)
        if view is not None and sys.stdin.isatty():
            print(
                f"the live page stays up at {view.url}: press Enter (or Ctrl-C) to stop", flush=True
            )
            sys.stdin.readline()
    except KeyboardInterrupt:
        print("interrupted: stopping the daemon")
    finally:
        if view is not None:
            view.stop()
        daemon.stop()
        server.join(30)
        sub.close()
    print(
        f"daemon stopped; {sum(e.type == 'cut' for e in events)} cuts, "
        f"{sum(e.type == 'segments' for e in events)} relabels"
    )
    if args.plot:
        try:
            timeline(events, rec, args.labels, stream, args.plot)
            print(f"wrote {args.plot}")
        except ImportError:
            print("matplotlib is not installed (pip install 'streamseg[plot]'): no picture")
    return 0


def _start_view(args, ep):
    """The live page on ``args.http`` (any free port if taken); None without aiohttp."""
    from streamseg.commands.view import http_address, start_view
    from streamseg.exceptions import StreamsegError

    try:
        import aiohttp  # noqa: F401
    except ImportError:
        print("live page: not started (pip install 'streamseg[view]' for streamseg view)")
        return None
    host, port = http_address(args.http)
    try:
        view = start_view(ep["publish"], ep["control"], f"{host}:{port}")
    except StreamsegError:
        view = start_view(ep["publish"], ep["control"], f"{host}:0")
    print(f"live page: {view.url}#stream=86_01  (open it in a browser)", flush=True)
    return view


def timeline(events, rec, labels_csv, sequence, path) -> None:
    """Draw human labels, the newest relabel of every frame, and the provisional cuts.

    Each relabelled id is drawn in the colour of the human action it matches best (the
    Hungarian matching of frames), so one colour is one action; ids no action matches get
    colours of their own, named in the key.
    """
    import numpy as np

    from streamseg.evaluation.labels import frame_labels, read_labels
    from streamseg.evaluation.metrics import matched_frame_accuracy
    from streamseg.plotting.timeline import timeline as draw

    n = rec.n_frames
    human = read_labels(labels_csv, sequence)
    names = list(dict.fromkeys(s.label for s in human))
    relab = np.full(n, -1)
    for ev in events:  # later revisions overwrite what they cover
        if ev.type == "segments":
            for a, b, lab in ev.segments:
                relab[a : min(b, n)] = lab
    truth = frame_labels(human, n)  # index into the sorted label names
    order = sorted(names)
    ok = (relab >= 0) & (truth >= 0)
    acc, match = matched_frame_accuracy(relab[ok], truth[ok]) if ok.any() else (0.0, {})
    key = list(names)
    colour_of = {}
    for lab in np.unique(relab[relab >= 0]):
        if int(lab) in match:
            colour_of[int(lab)] = names.index(order[match[int(lab)]])
        else:
            colour_of[int(lab)] = len(key)
            key.append(f"id {int(lab)} (no human match)")
    shown = np.array([colour_of.get(int(v), -1) for v in relab])
    cuts = [ev for ev in events if ev.type == "cut"]
    draw(
        path,
        n,
        rec.fps,
        [(s.start, s.end, s.label) for s in human],
        [
            ("relabelled\n(HACA, K found)", [], shown),
            (
                "provisional cuts\n(> = emitted)",
                [c.frame for c in cuts],
                None,
                [c.emitted_at for c in cuts],
            ),
        ],
        title=f"streamseg demo: CMU {sequence}, live (relabel frame accuracy {acc:.2f})",
        key=key,
    )
