"""Regenerate docs/img/view.png: the live view during replays of bundled recordings.

Starts a daemon (repetitions on) and the view on free loopback ports, replays CMU 86_01 and
14_14 (with their human labels) and four short CMU 02 trials at a few times real time, and
photographs the page in Debian's Chromium while 14_14 is running.

    .venv/bin/python docs/view_screenshot.py [--out docs/img/view.png] [--stream 14_14]
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import threading
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data"
ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def main() -> None:
    from playwright.sync_api import sync_playwright

    from streamseg.commands.replay import replay
    from streamseg.config import DaemonConfig
    from streamseg.daemon import Daemon
    from streamseg.io import read
    from streamseg.view.server import ViewThread

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "img" / "view.png"))
    ap.add_argument("--stream", default="14_14")
    ap.add_argument("--speed", type=float, default=3.0)
    ap.add_argument("--at", type=float, default=0.75, help="fraction of the stream shown")
    args = ap.parse_args()
    loop = "tcp://127.0.0.1:0"
    daemon = Daemon(
        DaemonConfig(
            ingest=loop, publish=loop, control=loop, repetitions=True, relabel_interval=5.0
        )
    )
    ep = daemon.bind()
    threading.Thread(target=daemon.run, daemon=True).start()
    daemon.ready.wait()
    view = ViewThread(ep["publish"], ep["control"])
    url = view.start()
    plays = [
        (
            DATA / "cmu86" / "86_01.amc.gz",
            DATA / "cmu86" / "86.asf",
            DATA / "cmu86" / "labels_86_01.csv",
        ),
        (
            DATA / "cmu_exercise" / "14_14.amc.gz",
            DATA / "cmu86" / "86.asf",
            DATA / "cmu_exercise" / "labels.csv",
        ),
    ]
    plays += [
        (DATA / "cmu02" / f"02_0{i}.amc.gz", DATA / "cmu02" / "02.asf", None) for i in (1, 3, 4, 5)
    ]
    n = {}
    senders = []
    for f, sk, labels in plays:
        rec = read(f, skeleton=sk)
        name = f.name.split(".")[0]
        n[name] = rec.n_frames
        senders.append(
            threading.Thread(
                target=replay,
                args=(rec, ep["ingest"]),
                daemon=True,
                kwargs=dict(stream=name, speed=args.speed, batch=4, labels=labels),
            )
        )
    for s in senders:
        s.start()
    profile = tempfile.mkdtemp()
    try:
        with sync_playwright() as pw:
            ctx = pw.chromium.launch_persistent_context(
                profile,
                executable_path=shutil.which("chromium"),
                args=ARGS,
                headless=True,
                viewport={"width": 1500, "height": 640},
            )
            page = ctx.new_page()
            page.goto(url + f"#stream={args.stream}")
            page.select_option("#window", "120")
            frame = int(n[args.stream] * args.at)
            page.wait_for_function(
                f"() => {{ const d = document.querySelector('#health dd[data-k=\"frame\"]');"
                f" return d && parseInt(d.textContent) >= {frame}; }}",
                timeout=300_000,
            )
            Path(args.out).parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=args.out)
            ctx.close()
    finally:
        shutil.rmtree(profile, ignore_errors=True)
        view.stop()
        daemon.stop()
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
