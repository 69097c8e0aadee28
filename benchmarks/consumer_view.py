"""What a consumer of the daemon's events knows about the boundaries, 1, 3 and 10 s after each
true boundary and at the end of the take.

A consumer's view at stream time ``t`` is built from the events published by then, applied in
order (docs/protocol.md): a ``cut`` adds its frame, a ``withdraw`` removes it, a ``confirm``
with a ``settled`` frame moves it there, and a ``segments`` revision ``[start, end)`` replaces
the revision boundaries inside ``(start, end)`` by its own (where the action label changes)
and every cut inside it published before it, settled or not (docs/protocol.md, Settled cuts:
a consumer that applies revisions takes theirs; a cut settled after the revision, or announced
after it, is in the view until the next revision covering it). The view is the union of both.

Scores, a boundary counting as known when one of the view lies within ``--tolerance`` (1.5 s)
of the true one:

* recall at ``d``: the share of true boundaries ``b`` for which the view at ``b + d`` s holds
  a boundary within the tolerance of ``b``;
* precision at ``d``: the share of the view's boundaries at ``b + d`` s that lie within the
  tolerance of a true boundary, averaged over the true boundaries ``b`` (a view that holds
  nothing yet is left out);
* end: the view after the stream's ``closed`` against the true boundaries, both ways.

F1 per recording from these, then the mean over recordings per set. ``latency``: per true
boundary that a cut event (any ``cut``, provisional or not) matched within the tolerance, the
stream time from the true boundary to the first such cut's emission (negative when the cut
came before the labelled frame), median over all; ``lag``: that cut's decision lag, from its
frame to its emission (``emitted_at - frame``). ``pending``: the detector's pending cuts
(two-stage decision or onset rule), and in brackets those within the tolerance of a true
boundary; ``near``: the share of the take's frames within the tolerance of one (the share
of pending cuts a detector placing them at random would have there).

The events come from the daemon's own per-stream code run in this process on stream time,
without sockets or a wall clock (``--source sim``, the default): the recording goes in
packets of ``--packet`` frames through :class:`streamseg.daemon.pipeline.StreamPipeline`,
relabels are due and taken as the daemon's loop takes them (one worker slot, a job's result
published ``--lag`` s of stream time after it was submitted, a due job waits for the running
one), and the final relabel runs after the end. ``--source daemon`` runs a real daemon on
loopback instead, replays each recording at ``--speed`` times real time, and takes the
events as a subscriber receives them, on each event's ``emitted_at``-free clock: the stream
frame the sender had sent when the event arrived (slower; wall time decides).

Sets: those of ``data/`` (:mod:`streamseg.evaluation.labelled_sets`) and ``heldout``, the CMU
takes of ``heldout/cmu`` that nothing is chosen on.

Run: .venv/bin/python benchmarks/consumer_view.py [--sets cmu,cmu02,hdm,heldout] [--chosen-on a,b]
     [--lag 0.5] [--source sim|daemon] [--delay S] [--early S] [--settle S] [--focus S]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import threading
import time
from types import SimpleNamespace

from _common import labelled, markdown_table

# the view and its scores; view_tradeoff and view_breakdown read them through this module
from view_scores import DELAYS, _triples, score_view, view_at  # noqa: F401

# --- the events -------------------------------------------------------------------------------


def _algorithms(args):
    from streamseg.config import LOFConfig
    from streamseg.config.memory import LabelMemoryConfig
    from streamseg.daemon.algorithms import Algorithms

    lof = LOFConfig(**_lof_overrides(args))
    return Algorithms(
        lof_config=lof,
        memory_config=LabelMemoryConfig(),
        **_settle_kw(args),
        **({"alternations": False} if args.no_alternations else {}),
    )


#: option -> the LOFConfig field it sets
LOF_OPTIONS = {
    "delay": "delay_s",
    "early": "early_delay_s",
    "window": "window_s",
    "refine": "refine_s",
    "step": "step_s",
    "k": "k",
    "onset": "onset_mads",
    "onset-rises": "onset_rises",
    "onset-lead": "onset_lead_s",
    "onset-gap": "onset_gap_s",
}


def _lof_overrides(args) -> dict:
    over = {
        f: getattr(args, o.replace("-", "_"))
        for o, f in LOF_OPTIONS.items()
        if getattr(args, o.replace("-", "_")) is not None
    }
    if over.get("onset_mads") == 0:  # `--onset 0`: no onset rule (one stage)
        over["onset_mads"] = None
    return over


def _settle_kw(args) -> dict:
    from streamseg.daemon.algorithms import Algorithms

    kw = {}
    params = Algorithms.__init__.__code__.co_varnames
    if "settle_s" in params:
        if args.settle is not None:
            kw["settle_s"] = args.settle
        if args.focus is not None:
            kw["focus_s"] = args.focus
        if args.radius is not None:
            kw["radius_s"] = args.radius
    return kw


def _cut_event(stream, frame, score, emitted, kind, settled=None, revision=None):
    """A pipeline step's cut tuple as the protocol event the daemon publishes."""
    from streamseg import protocol

    if kind in ("cut", "pending", "found"):
        return protocol.Cut(
            stream,
            frame,
            0.0,
            score,
            emitted,
            kind != "found",
            True if kind == "pending" else None,
            **({"revision": revision} if revision is not None else {}),
        )
    if kind in ("confirm", "confirmed"):
        extra = {"settled": settled, "revision": revision} if kind == "confirmed" else {}
        return protocol.Confirm(stream, frame, 0.0, score, emitted, **extra)
    extra = {"revision": revision} if kind == "rejected" else {}
    return protocol.Withdraw(stream, frame, 0.0, emitted, kind == "moved", **extra)


def simulate(item, algorithms, history: float, interval: float, lag_s: float, packet: int):
    """The stream's events as ``(t, event)``, ``t`` the frames the sender had sent when it was
    published; the daemon's scheduling (server.py, intake.py) on stream time."""
    from streamseg import protocol
    from streamseg.daemon.options import skeleton_from
    from streamseg.daemon.pipeline import StreamPipeline
    from streamseg.daemon.relabel_job import relabel

    rec = item.recording
    fps, n = float(rec.fps), rec.n_frames
    sk = rec.skeleton
    pipe = StreamPipeline(
        skeleton_from(sk.names, sk.parents, sk.units, sk.up), fps, algorithms, history
    )
    settling = hasattr(pipe, "relabel_due")
    lag = int(round(lag_s * fps))
    state = {
        "next": int(round(interval * fps)),
        "job": None,
        "due": False,
        "rev": 0,
        "work": [[0, 0.0], [0, 0.0]],
    }  # [count, seconds] of the cadence's, the focused
    out = []

    def cuts_at(t, cuts):
        for c in cuts:
            out.append((t, _cut_event("s", *c)))

    def due() -> bool:
        if settling:
            return pipe.relabel_due(state["next"])
        return pipe.learned >= state["next"]

    def submit(t, final):
        if settling:
            feats, frames, focused = pipe.relabel_snapshot(final or pipe.learned >= state["next"])
        else:
            (feats, frames), focused = pipe.snapshot(), False
        if feats.shape[0] < 2:
            return False
        if not focused:
            state["next"] = pipe.learned + int(round(interval * fps))
        result = relabel(algorithms, feats, frames, fps, pipe.previous, tuple(pipe.cut_frames))
        state["work"][focused][0] += 1
        state["work"][focused][1] += result.elapsed
        state["job"] = (t + lag, result, final, focused)
        return True

    def publish(t):
        ready, result, final, focused = state["job"]
        state["job"] = None
        state["rev"] += 1
        out.append(
            (
                t,
                protocol.Segments(
                    "s", state["rev"], result.start, result.end, result.segments, final, 0.0
                ),
            )
        )
        if settling:
            for c in pipe.relabelled(result, final, t, focused):
                out.append((t, _cut_event("s", *c, state["rev"])))
        else:
            pipe.previous = result.window

    for i in range(0, n, packet):
        cuts, _, _ = pipe.push(rec.positions[i : i + packet], i)
        t = min(i + packet, n)
        cuts_at(t, cuts)
        if state["job"] is not None and t >= state["job"][0]:
            publish(t)
        if not state["due"] and interval > 0 and due():
            state["due"] = True
        if state["due"] and state["job"] is None:
            state["due"] = False
            submit(t, False)
    cuts_at(n, pipe.finish())
    t = n
    if state["job"] is not None:  # the running job ends first, then the final one runs
        t = max(t, state["job"][0])
        publish(t)
    if interval > 0 and submit(t, True):
        publish(state["job"][0])
    WORK[item.name] = state["work"]
    return out, n


WORK: dict = {}  # recording -> relabels [count, seconds] of the cadence (final included), focused


def from_daemon(item, algorithms, history, interval, speed):
    """The same through a real daemon on loopback: replay at ``speed`` x real time."""

    import zmq

    from streamseg import protocol
    from streamseg.client import subscriber
    from streamseg.commands.replay import announce_of
    from streamseg.config import DaemonConfig
    from streamseg.daemon import Daemon

    loop = "tcp://127.0.0.1:0"
    cfg = DaemonConfig(
        ingest=loop,
        publish=loop,
        control=loop,
        relabel_history=history,
        relabel_interval=interval,
        heartbeat=0,
    )
    d = Daemon(cfg, algorithms)
    ep = d.bind()
    th = threading.Thread(target=d.run, daemon=True)
    th.start()
    d.ready.wait(600)
    ctx = zmq.Context.instance()
    sub = subscriber(ep["publish"], stream="s")
    push = ctx.socket(zmq.PUSH)
    push.connect(ep["ingest"])
    time.sleep(0.3)
    rec = item.recording
    fps, n = float(rec.fps), rec.n_frames
    push.send_multipart(protocol.encode(announce_of(rec, "s")))
    sent = [0]
    out = []
    done = threading.Event()

    def listen():
        while True:
            if not sub.poll(100):
                continue
            ev = protocol.decode(sub.recv_multipart())
            if ev.type in ("cut", "confirm", "withdraw", "segments"):
                out.append((sent[0], ev))
            if ev.type == "closed":
                done.set()
                return

    lt = threading.Thread(target=listen, daemon=True)
    lt.start()
    t0 = time.perf_counter()
    step = 4
    for i in range(0, n, step):
        wait = t0 + i / (fps * speed) - time.perf_counter()
        if wait > 0:
            time.sleep(wait)
        pos = rec.positions[i : i + step]
        push.send_multipart(protocol.encode(protocol.Frames("s", i, i / fps, pos)))
        sent[0] = i + pos.shape[0]
    push.send_multipart(protocol.encode(protocol.End("s")))
    done.wait(300)
    d.stop()
    th.join(60)
    sub.close(0)
    push.close(0)
    return out, n


def from_cli(item, args):
    """``streamseg serve`` + ``streamseg replay --speed`` + ``streamseg listen --jsonl`` as
    separate processes on free loopback ports (``serve`` binds port 0 and prints the ports it
    got, so runs can go side by side); an event's time is the stream frame the replay had
    reached when its line arrived (its start, taken as the latest that no event's
    ``emitted_at`` contradicts, + elapsed wall time x fps x speed)."""
    import os
    import subprocess
    import tempfile

    from streamseg.client import request
    from streamseg.io import write_npz

    exe = os.path.join(os.path.dirname(sys.executable), "streamseg")
    loop = "tcp://127.0.0.1:0"
    state = tempfile.mkdtemp(prefix="consumer-view-")
    serve = subprocess.Popen(
        [
            exe,
            "serve",
            "--ingest",
            loop,
            "--publish",
            loop,
            "--control",
            loop,
            "--state-dir",
            state,
            *_serve_flags(args),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        ing, pub, ctl = _bound(serve)
        deadline = time.monotonic() + 600
        while True:  # ready once control answers (the kernels are warm)
            try:
                request(ctl, "ping", timeout=1.0)
                break
            except Exception:
                if time.monotonic() > deadline or serve.poll() is not None:
                    raise RuntimeError("streamseg serve did not start") from None
        listen = subprocess.Popen(
            [
                exe,
                "listen",
                "--from",
                pub,
                "--control",
                ctl,
                "--stream",
                "s",
                "--jsonl",
                "--until-end",
                "--timeout",
                "600",
            ],
            stdout=subprocess.PIPE,
            text=True,
            env=dict(os.environ, PYTHONUNBUFFERED="1"),
        )
        assert json.loads(listen.stdout.readline())["type"] == "state"
        rec = item.recording
        fps, n = float(rec.fps), rec.n_frames
        path = os.path.join(state, "take.npz")  # a joined sequence has no file of its own
        write_npz(path, rec)
        replay = subprocess.Popen(
            [
                exe,
                "replay",
                path,
                "--to",
                ing,
                "--speed",
                str(args.speed),
                "--stream",
                "s",
                "--batch",
                "4",
            ],
            stdout=subprocess.DEVNULL,
        )
        raw = []
        for line in listen.stdout:
            now = time.monotonic()
            d = json.loads(line)
            if d.get("type") in ("cut", "confirm", "withdraw", "segments"):
                d.setdefault("provisional", True)
                raw.append((now, SimpleNamespace(**d)))
        # the replay's clock: frame f was sent at t0 + f / (fps x speed), t0 after the
        # replay process started; no event can arrive before the frame that made it was sent
        rate = fps * args.speed
        t0 = min(w - e.emitted_at / rate for w, e in raw if hasattr(e, "emitted_at"))
        out = [(min((w - t0) * rate, n + 10 * fps), e) for w, e in raw]
        replay.wait(60)
        listen.wait(60)
        return out, n
    finally:
        serve.terminate()
        serve.wait(60)


def _bound(serve) -> tuple:
    """The ingest, publish and control endpoints of ``serve``'s first line (``streamseg serve:
    ingest=... publish=... control=...``, printed once its sockets are bound)."""
    line = serve.stdout.readline()
    if not line.startswith("streamseg serve: "):
        raise RuntimeError(f"streamseg serve did not start: {line.strip()!r}")
    got = dict(kv.split("=", 1) for kv in line.split(": ", 1)[1].split())
    # whatever it prints later is read and dropped, so a full pipe never blocks it
    threading.Thread(target=serve.stdout.read, daemon=True).start()
    return got["ingest"], got["publish"], got["control"]


def _serve_flags(args) -> list:
    flags = []
    if args.settle is not None:
        flags += ["--settle", str(args.settle)]
    if args.focus is not None:
        flags += ["--focus", str(args.focus)]
    return flags


# --- the table --------------------------------------------------------------------------------


def _saved(path) -> dict:
    """Recording name -> (events, n) of a ``--save`` file."""
    out = {}
    for line in open(path):
        d = json.loads(line)
        evs, _ = out.setdefault(d["rec"], ([], d["n"]))
        ev = dict(d["ev"])
        ev.setdefault("provisional", True)
        evs.append((d["t"], SimpleNamespace(**ev)))
    return out


def run(args) -> list:
    sets = tuple(args.sets.split(","))
    items = labelled(tuple(s for s in sets if s != "heldout")) if set(sets) - {"heldout"} else []
    if "heldout" in sets:
        items += heldout()
    if args.only:
        keep = set(args.only.split(","))
        items = [i for i in items if i.name in keep]
    saved = _saved(args.load) if args.load else None
    rows = []
    for item in items:
        algorithms = _algorithms(args)
        t = time.perf_counter()
        if saved is not None:
            if item.name not in saved:
                continue
            events, n = saved[item.name]
        elif args.source == "sim":
            events, n = simulate(
                item, algorithms, args.history, args.interval, args.lag, args.packet
            )
        elif args.source == "daemon":
            events, n = from_daemon(item, algorithms, args.history, args.interval, args.speed)
        else:
            events, n = from_cli(item, args)
        if args.save and saved is None:
            from streamseg import protocol, strict_json

            with open(args.save, "a") as fh:
                for when, ev in events:
                    # events read from `listen --jsonl` are plain namespaces already
                    body = vars(ev) if isinstance(ev, SimpleNamespace) else protocol.to_json(ev)
                    fh.write(
                        strict_json.dumps({"rec": item.name, "t": when, "n": n, "ev": body}) + "\n"
                    )
        fps = float(item.recording.fps)
        res = score_view(events, n, item.cuts, fps, args.tolerance)
        res["cuts"] = score_view(events, n, item.cuts, fps, args.tolerance, cuts_only=True)
        res["cuts"]["name"], res["cuts"]["group"] = item.name, item.group
        res["name"], res["group"] = item.name, item.group
        res["seconds"] = time.perf_counter() - t
        rows.append(res)
        if args.verbose:
            print(
                item.name,
                {k: v for k, v in res.items() if k not in ("latency", "lag")},
                file=sys.stderr,
                flush=True,
            )
    return rows


def heldout() -> list:
    """The held-out CMU takes of ``heldout/cmu`` (86_09, 13_29, 13_30, 13_31: nothing is
    chosen on them), set ``heldout``."""
    from _common import ROOT

    from streamseg.evaluation.corpus import discover

    items = discover(ROOT / "heldout")
    for item in items:
        item.group = "heldout"
    return items


def table(rows, chosen=()) -> str:
    header = (
        ["set", "recordings"]
        + [f"{lab} {m}" for lab in ("1 s", "3 s", "10 s", "end") for m in ("R", "P", "F1")]
        + ["latency med s", "lag med s", "unresolved", "pending (near a boundary)", "near"]
    )
    work = any(r["name"] in WORK for r in rows)
    if work:
        header += ["relabels (focused)", "relabel s (focused)"]
    groups = {}
    for r in rows:
        if r["name"] in chosen:
            continue
        groups.setdefault(r["group"], []).append(r)
    if len(groups) > 1:
        groups["all"] = [r for g in list(groups.values()) for r in g]
    out = []
    for g, rs in groups.items():
        cells = [g, len(rs)]
        for key in (*DELAYS, "end"):
            for j in range(3):
                cells.append(f"{statistics.mean(r[key][j] for r in rs):.3f}")
        lat = [x for r in rs for x in r["latency"]]
        cells.append(f"{statistics.median(lat):.2f}" if lat else "-")
        lag = [x for r in rs for x in r["lag"]]
        cells.append(f"{statistics.median(lag):.2f}" if lag else "-")
        cells.append(sum(r["unresolved"] for r in rs))
        pend = [r["pending"] for r in rs]
        cells.append(f"{sum(p[0] for p in pend)} ({sum(p[1] for p in pend)})")
        cells.append(f"{statistics.mean(r['near'] for r in rs):.2f}")
        if work:
            w = [WORK.get(r["name"], [[0, 0.0], [0, 0.0]]) for r in rs]
            cells.append(f"{sum(x[0][0] + x[1][0] for x in w)} ({sum(x[1][0] for x in w)})")
            cells.append(f"{sum(x[0][1] + x[1][1] for x in w):.1f} ({sum(x[1][1] for x in w):.1f})")
        out.append(cells)
    return markdown_table(header, out)


def parser() -> argparse.ArgumentParser:
    """The command line (also :mod:`view_tradeoff`'s, per detector setting)."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sets", default="cmu,cmu02,hdm")
    p.add_argument("--only", default="", help="comma-separated recording names")
    p.add_argument(
        "--chosen-on",
        default="",
        help="recordings left out of the table (the parameters were chosen on them)",
    )
    p.add_argument("--source", choices=("sim", "daemon", "cli"), default="sim")
    p.add_argument(
        "--lag",
        type=float,
        default=0.5,
        help="stream seconds from a relabel's submission to its result (sim)",
    )
    p.add_argument("--speed", type=float, default=2.0, help="replay speed (daemon)")
    p.add_argument("--packet", type=int, default=4, help="frames per packet (sim)")
    p.add_argument("--history", type=float, default=60.0)
    p.add_argument("--interval", type=float, default=5.0)
    p.add_argument("--tolerance", type=float, default=1.5)
    for opt, field in LOF_OPTIONS.items():
        kind = int if field in ("k", "onset_rises") else float
        p.add_argument(f"--{opt}", type=kind, default=None, help=f"LOFConfig.{field}")
    p.add_argument("--settle", type=float, default=None)
    p.add_argument("--focus", type=float, default=None)
    p.add_argument("--radius", type=float, default=None)
    p.add_argument(
        "--no-alternations",
        action="store_true",
        help="publish HACA's labels "
        "as they are (no merged alternations, streamseg.daemon.alternation)",
    )
    p.add_argument("--verbose", action="store_true")
    p.add_argument("--save", default="", help="append every event as JSON lines to this file")
    p.add_argument("--load", default="", help="score the events of a --save file instead")
    return p


def main(argv=None) -> None:
    args = parser().parse_args(argv)
    rows = run(args)
    chosen = set(filter(None, args.chosen_on.split(",")))
    print("The view (cut, confirm, withdraw and segments events):")
    print(table(rows, chosen))
    print()
    print("Cut, confirm and withdraw events alone:")
    print(table([r["cuts"] for r in rows], chosen))
    if chosen:
        print()
        print("chosen on:")
        print(table([r for r in rows if r["name"] in chosen]))


if __name__ == "__main__":
    main()
