"""The live view: events per second it forwards, and the latency from an event to the page.

Run: ``.venv/bin/python benchmarks/view_latency.py [--runs 3] [--streams 1,100]
[--events 50000] [--speed 4]`` (needs the ``view`` and ``test`` extras and Debian's
``chromium``).

1. Forwarding capacity: a PUB socket of our own publishes ``--events`` real protocol ``cut``
   events as fast as it can, spread over S streams, into a view (no daemon, so the daemon's
   pace is not what is measured) with one page connected; every 200th event goes to a
   ``probe`` stream the page has open. Events/s = events / (first sent -> the view's hub has
   applied the last); page messages/s = WebSocket messages the server sent per second (the
   coalescing: one ``rows`` message per tick, not one per event); probe latency = publish
   -> the probe's cut line is in the page's DOM, under that saturation. Baseline, alternated
   with the view runs: a bare SUB ``recv_multipart`` + ``protocol.decode`` loop on the same
   publisher (the least any Python subscriber pays); the ratio is view / baseline.
2. Daemon to DOM: a real daemon (LOF cuts, relabelling off so 100 streams fit the machine)
   fed S copies of CMU 86_01 at ``--speed`` times real time, round robin on one socket; a
   listener in this process stamps each ``cut`` as the daemon's subscribers receive it; the
   page (open on ``s000``) stamps when the cut's line entered the DOM (timeline) and when the
   list row of any stream first showed that many cuts (list). Latency = page - listener, per
   cut, median and p95 over the run's cuts. Its baseline is the coalescing tick (0.1 s, so
   50 ms median by itself). "Page script busy": the share of the run's wall time the page's
   script spent handling updates (parsing, model, DOM), whether 1 or 100 streams flow.

Every figure is the median over ``--runs`` runs (fresh daemon, view and page each run).
Wall time on a shared machine: the ratios matter more than the absolute figures.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import zmq

from streamseg import protocol as P
from streamseg.client import subscriber
from streamseg.commands.replay import announce_of
from streamseg.config import DaemonConfig
from streamseg.daemon import Daemon
from streamseg.io import read
from streamseg.view.server import ViewThread

DATA = Path(__file__).resolve().parents[1] / "data" / "cmu86"
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
LOOP = "tcp://127.0.0.1:0"


def pct(values, q):
    return float(np.percentile(values, q)) if len(values) else float("nan")


def page_trace(page):
    return page.evaluate("() => window.viewTrace")


def events(n_streams: int, n_events: int) -> list:
    names = [f"b{i:03d}" for i in range(n_streams)]
    return [P.encode(P.Cut(names[i % n_streams], i, 0.0, 1.0, i)) for i in range(n_events)]


def bare(n_streams: int, n_events: int) -> float:
    """Baseline: events/s of a bare SUB ``recv_multipart`` + ``protocol.decode`` loop on the
    same flat-out publisher (what any Python subscriber pays before doing anything)."""
    ctx = zmq.Context.instance()
    pub = ctx.socket(zmq.PUB)
    pub.setsockopt(zmq.SNDHWM, 0)
    pub.bind("tcp://127.0.0.1:*")
    sub = ctx.socket(zmq.SUB)
    sub.setsockopt(zmq.RCVHWM, 0)
    sub.setsockopt(zmq.SUBSCRIBE, b"")
    sub.connect(pub.getsockopt_string(zmq.LAST_ENDPOINT))
    msgs = events(n_streams, n_events)
    while not sub.poll(10):  # handshake: the subscription is live
        pub.send_multipart(P.encode(P.Cut("hello", 0, 0.0, 1.0, 0)))
    while sub.poll(0):
        sub.recv_multipart()
    done = threading.Event()

    def receive():
        for _ in range(n_events):
            P.decode(sub.recv_multipart())
        done.set()

    t = threading.Thread(target=receive)
    t.start()
    t0 = time.perf_counter()
    for m in msgs:
        pub.send_multipart(m)
    done.wait()
    elapsed = time.perf_counter() - t0
    t.join()
    sub.close()
    pub.close()
    return n_events / elapsed


def capacity(browser, n_streams: int, n_events: int) -> dict:
    ctx = zmq.Context.instance()
    pub = ctx.socket(zmq.PUB)
    pub.setsockopt(zmq.SNDHWM, 0)
    pub.bind("tcp://127.0.0.1:*")
    endpoint = pub.getsockopt_string(zmq.LAST_ENDPOINT)
    view = ViewThread(endpoint, None)
    url = view.start()
    page = browser.new_page()
    try:
        page.goto(url + "?trace=1#stream=probe")
        frame = 0
        while not page.query_selector("#cut-layer line.cut"):  # handshake: the chain works
            pub.send_multipart(P.encode(P.Cut("probe", frame, 0.0, 1.0, frame)))
            frame += 1
            page.wait_for_timeout(20)
        hub = view.server.hub
        base, sent0 = hub.applied, view.server.sent
        msgs = events(n_streams, n_events)
        sends = {}
        probe0 = 10_000_000
        t0 = time.perf_counter()
        w0 = time.time() * 1000
        for i, m in enumerate(msgs):
            if i % 200 == 0:
                f = probe0 + i
                sends[f] = time.time() * 1000
                pub.send_multipart(P.encode(P.Cut("probe", f, 0.0, 1.0, f)))
            else:
                pub.send_multipart(m)
        total = n_events
        while hub.applied - base < total:
            time.sleep(0.001)
        elapsed = time.perf_counter() - t0
        page.wait_for_function(
            f"() => document.querySelectorAll('#cut-layer line.cut')"
            f".length >= {frame + len(sends)}",
            timeout=120_000,
        )
        sent = view.server.sent - sent0
        shown = {f: t for s, kind, f, t in page_trace(page) if kind == "cut" and s == "probe"}
        lat = [shown[f] - sends[f] for f in sends]
        span = (time.time() * 1000 - w0) / 1000
        return {
            "events_s": total / elapsed,
            "page_msgs_s": sent / span,
            "p50_ms": pct(lat, 50),
            "p95_ms": pct(lat, 95),
        }
    finally:
        page.close()
        view.stop()
        pub.close()


def daemon_to_dom(browser, rec, n_streams: int, speed: float) -> dict:
    daemon = Daemon(
        DaemonConfig(
            ingest=LOOP,
            publish=LOOP,
            control=LOOP,
            heartbeat=1.0,
            relabel_interval=0,
            max_streams=max(100, n_streams),
        )
    )
    ep = daemon.bind()
    dt = threading.Thread(target=daemon.run, daemon=True)
    dt.start()
    daemon.ready.wait()
    got: dict = {}  # (stream, k) -> ms when the k-th cut of the stream reached a subscriber
    counts: dict = {}
    heard, stop = threading.Event(), threading.Event()

    def listen():
        sub = subscriber(ep["publish"])
        while not stop.is_set():
            if not sub.poll(100):
                continue
            ev = P.decode(sub.recv_multipart())
            heard.set()
            if ev.type == "cut":
                counts[ev.stream] = counts.get(ev.stream, 0) + 1
                got[(ev.stream, counts[ev.stream])] = (time.time() * 1000, ev.frame)
        sub.close()

    lt = threading.Thread(target=listen, daemon=True)
    lt.start()
    view = ViewThread(ep["publish"], ep["control"])
    url = view.start()
    page = browser.new_page()
    names = [f"s{i:03d}" for i in range(n_streams)]
    try:
        heard.wait(30)  # the daemon's heartbeat reached the listener
        page.goto(url + "?trace=1#stream=s000")
        page.wait_for_function(
            "() => /\\b[1-9][0-9]* events/.test(document.querySelector('#totals').textContent)"
        )
        push = zmq.Context.instance().socket(zmq.PUSH)
        push.connect(ep["ingest"])
        for name in names:
            push.send_multipart(P.encode(announce_of(rec, name)))
        busy0 = page.evaluate("() => window.viewBusyMs")
        t0 = time.perf_counter()
        batch = 4
        for a in range(0, rec.n_frames, batch):
            wait = t0 + a / (rec.fps * speed) - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            chunk = rec.positions[a : a + batch]
            now = time.time()
            for name in names:
                push.send_multipart(P.encode(P.Frames(name, a, now, chunk)))
        for name in names:
            push.send_multipart(P.encode(P.End(name)))
        push.close()
        page.wait_for_function(
            f"() => document.querySelector('#count').textContent"
            f".startsWith('{n_streams} streams (0 open)')",
            timeout=300_000,
        )
        busy = (page.evaluate("() => window.viewBusyMs") - busy0) / 1000
        span = time.perf_counter() - t0
        n0 = counts.get("s000", 0)
        page.wait_for_function(
            f"() => document.querySelectorAll('#cut-layer line.cut').length >= {n0}", timeout=60_000
        )
        trace = page_trace(page)
        dom = {f: t for s, kind, f, t in trace if kind == "cut" and s == "s000"}
        timeline = [dom[f] - t for (s, _), (t, f) in got.items() if s == "s000" and f in dom]
        first_row: dict = {}
        for s, kind, k, t in trace:
            if kind == "row":
                for j in range(1, k + 1):
                    first_row.setdefault((s, j), t)
        rows = [first_row[key] - t for key, (t, _) in got.items() if key in first_row]
        return {
            "cuts": len(got),
            "busy": busy / span,
            "timeline_p50_ms": pct(timeline, 50),
            "timeline_p95_ms": pct(timeline, 95),
            "list_p50_ms": pct(rows, 50),
            "list_p95_ms": pct(rows, 95),
            "list_n": len(rows),
            "timeline_n": len(timeline),
        }
    finally:
        page.close()
        view.stop()
        stop.set()
        lt.join(5)
        daemon.stop()
        dt.join(30)


def main() -> None:
    from playwright.sync_api import sync_playwright

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--streams", default="1,100")
    ap.add_argument("--events", type=int, default=50_000)
    ap.add_argument("--speed", type=float, default=4.0)
    args = ap.parse_args()
    counts = [int(s) for s in args.streams.split(",")]
    rec = read(DATA / "86_01.amc.gz", skeleton=DATA / "86.asf")
    profile = tempfile.mkdtemp(prefix="streamseg-bench-")
    med = statistics.median
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch_persistent_context(
                profile,
                executable_path=shutil.which("chromium"),
                args=ARGS,
                headless=True,
                viewport={"width": 1400, "height": 800},
            )
            print(
                f"1. forwarding capacity: {args.events} cut events published as fast as "
                f"possible, one page open; median of {args.runs} runs"
            )
            print(
                "| streams | bare SUB + decode (events/s) | applied by the view (events/s) | "
                "ratio | page messages/s | probe latency p50 / p95 (ms) |"
            )
            print("|---:|---:|---:|---:|---:|---:|")
            for n in counts:
                rs, base = [], []
                for _ in range(args.runs):  # alternated, so both see the same machine
                    base.append(bare(n, args.events))
                    rs.append(capacity(browser, n, args.events))
                view_rate = med(r["events_s"] for r in rs)
                print(
                    f"| {n} | {med(base):,.0f} | {view_rate:,.0f} | "
                    f"{view_rate / med(base):.2f} | {med(r['page_msgs_s'] for r in rs):.1f} | "
                    f"{med(r['p50_ms'] for r in rs):.0f} / {med(r['p95_ms'] for r in rs):.0f}"
                    " |",
                    flush=True,
                )
            print(
                f"\n2. daemon event -> page DOM: S x CMU 86_01 at {args.speed:g}x real time, "
                f"LOF cuts; median of {args.runs} runs"
            )
            print(
                "| streams | cuts published | timeline p50 / p95 (ms) | list row p50 / p95 "
                "(ms) | page script busy |"
            )
            print("|---:|---:|---:|---:|---:|")
            for n in counts:
                rs = [daemon_to_dom(browser, rec, n, args.speed) for _ in range(args.runs)]
                print(
                    f"| {n} | {med(r['cuts'] for r in rs):.0f} | "
                    f"{med(r['timeline_p50_ms'] for r in rs):.0f} / "
                    f"{med(r['timeline_p95_ms'] for r in rs):.0f} | "
                    f"{med(r['list_p50_ms'] for r in rs):.0f} / "
                    f"{med(r['list_p95_ms'] for r in rs):.0f} | "
                    f"{100 * med(r['busy'] for r in rs):.1f}% |",
                    flush=True,
                )
            browser.close()
    finally:
        shutil.rmtree(profile, ignore_errors=True)


if __name__ == "__main__":
    main()
