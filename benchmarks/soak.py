"""A soak that tries to kill the daemon: one `streamseg serve` for N minutes under everything
at once, a SIGKILL and restart every minute or so.

Run: ``.venv/bin/python benchmarks/soak.py [--minutes 10] [--seed 1]``

Load, all at the same time, each chosen at random from ``--seed``:

- replays of CMU 86_01 slices with :func:`streamseg.commands.replay.replay`, at ``--speed
  0`` (batches of 1 to 240 frames) and at real time, each on a connection of its own that
  ends right after the stream's ``end``;
- raw PUSH senders of 1 to 12,000-frame packets in float32 and float64 (up to 8.9 MB), that
  close right after their last packet, some re-announcing their stream half-way;
- subscribers that read every event (the record checked against the log), a slow one, and
  ones that connect, read a few events and vanish;
- control requests (``stats``, ``streams``, ``state``) all the time;
- a SIGKILL and a restart on the same state directory every ``--kill-every`` seconds.

Reported: daemon deaths other than the kills (a death is the process gone when this script
did not kill it), frames sent and frames taken (the daemon's ``frames`` total of each run,
read just before each kill and at the end: frames in flight at a kill are lost by design),
numbered events a subscriber saw live that the log does not hold as seen, the resident
memory peak over the runs beside ``ingest_bytes`` and the streams open, and the packet
latency p50/p99 of the last ``stats`` of each run.
"""

from __future__ import annotations

import argparse
import random
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import zmq

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.faults._served import Served, missing_from_log, numbered, recording  # noqa: E402
from streamseg import protocol as P  # noqa: E402
from streamseg.client import subscriber  # noqa: E402
from streamseg.commands.replay import NoDaemon, announce_of, replay  # noqa: E402

INGEST_BYTES = 256 << 20  # the default budget


class Load:
    """The senders, subscribers and control requests of one soak, as threads."""

    def __init__(self, served: Served, rec, seed: int, deadline: float):
        self.d, self.rec, self.deadline = served, rec, deadline
        self.rng = random.Random(seed)
        self.lock = threading.Lock()
        self.sent = 0
        self.seen: list = []  # numbered events a full subscriber saw live
        self.errors: list = []  # exceptions in load threads (a bug of the soak, or the daemon)
        self.n = 0
        self.stopping = threading.Event()
        self.threads: list = []

    def _id(self, kind: str) -> str:
        with self.lock:
            self.n += 1
            return f"{kind}{self.n}"

    def _count(self, frames: int) -> None:
        with self.lock:
            self.sent += frames

    def spawn(self, fn, *args) -> None:
        def guarded():
            try:
                fn(*args)
            except Exception as err:  # recorded, reported; the soak goes on
                self.errors.append(f"{fn.__name__}: {type(err).__name__}: {err}")

        t = threading.Thread(target=guarded, daemon=True)
        t.start()
        self.threads.append(t)

    # --- senders ------------------------------------------------------------------------------

    def replayer(self) -> None:
        rng = self.rng
        while not self.stopping.is_set():
            a = rng.randrange(0, self.rec.n_frames - 600)
            part = self.rec.slice(a, a + rng.randrange(240, 600))
            realtime = rng.random() < 0.3
            try:
                n = replay(
                    part,
                    self.d.ep["ingest"],
                    stream=self._id("rp"),
                    speed=1.0 if realtime else 0.0,
                    batch=4 if realtime else rng.choice([1, 20, 120, 240]),
                    dtype=rng.choice([np.float32, np.float64]),
                    wait=5.0,
                )
            except NoDaemon:  # killed while it sent: a live sender loses these frames
                continue
            self._count(n)

    def _send(self, push, daemon, parts) -> None:
        """Send ``parts``; a full queue is the daemon's backpressure: wait while the daemon
        the take is sent to runs (zmq.Again once it was killed)."""
        while True:
            try:
                return push.send_multipart(parts)
            except zmq.Again:
                if self.d.proc is not daemon or daemon.poll() is not None:
                    raise
                if self.stopping.is_set():
                    raise

    def raw_sender(self) -> None:
        rng, rec = self.rng, self.rec
        while not self.stopping.is_set():
            stream = self._id("raw")
            push = zmq.Context.instance().socket(zmq.PUSH)
            push.setsockopt(zmq.SNDHWM, 4)
            push.setsockopt(zmq.SNDTIMEO, 2000)
            push.connect(self.d.ep["ingest"])
            size = rng.choice([1, 7, 100, 1000, 12_000])
            dtype = rng.choice([np.float32, np.float64])
            packets = max(1, min(20, 24_000 // size))
            # a re-announce half-way starts the stream over (its first take is closed)
            half = packets // 2 if rng.random() < 0.2 else None
            daemon = self.d.proc  # the daemon this take is sent to

            try:
                self._send(push, daemon, P.encode(announce_of(rec, stream)))
                for k in range(packets):
                    if k == half:
                        self._send(push, daemon, P.encode(announce_of(rec, stream)))
                    first = (k - half if half is not None and k >= half else k) * size
                    idx = (np.arange(size) + k * size) % rec.n_frames
                    pos = rec.positions[idx].astype(dtype)
                    self._send(push, daemon, P.encode(P.Frames(stream, first, 0.0, pos)))
                    self._count(size)
                self._send(push, daemon, P.encode(P.End(stream)))
            except zmq.Again:  # the daemon is down (killed): a live sender loses these
                pass
            # the connection ends right after its last packet is handed over (across a
            # restart too: the endpoint stays the same)
            push.close(linger=10_000)
            self.stopping.wait(rng.uniform(0.0, 0.5))

    # --- subscribers and control ---------------------------------------------------------------

    def full_subscriber(self) -> None:
        sub = subscriber(self.d.ep["publish"])
        while not self.stopping.is_set():
            if sub.poll(200):
                ev = P.decode(sub.recv_multipart())
                if getattr(ev, "seq", None) is not None and ev.type != "stats":
                    self.seen.append(ev)
        sub.close(linger=0)

    def slow_subscriber(self) -> None:
        sub = zmq.Context.instance().socket(zmq.SUB)
        sub.setsockopt(zmq.RCVHWM, 100)  # before connect: it drops what it cannot keep
        sub.setsockopt(zmq.SUBSCRIBE, b"")
        sub.connect(self.d.ep["publish"])
        while not self.stopping.is_set():
            if sub.poll(200):
                sub.recv_multipart()
                self.stopping.wait(0.05)  # far slower than the events come
        sub.close(linger=0)

    def vanishing_subscribers(self) -> None:
        while not self.stopping.is_set():
            sub = subscriber(self.d.ep["publish"])
            for _ in range(self.rng.randrange(1, 20)):
                if not sub.poll(200):
                    break
                sub.recv_multipart()
            sub.close(linger=0)

    def controller(self) -> None:
        ops = ["stats", "streams", "state"]
        while not self.stopping.is_set():
            op = self.rng.choice(ops)
            try:
                self.d.request(op, timeout=2.0, **({"stream": "raw1"} if op == "state" else {}))
            except TimeoutError:  # the daemon is being restarted
                pass
            self.stopping.wait(0.02)

    def start(self) -> None:
        for fn in (
            self.replayer,
            self.replayer,
            self.raw_sender,
            self.raw_sender,
            self.full_subscriber,
            self.slow_subscriber,
            self.vanishing_subscribers,
            self.controller,
        ):
            self.spawn(fn)

    def stop(self) -> None:
        self.stopping.set()
        for t in self.threads:
            t.join(60)


def run_soak(seconds: float, tmp: Path, seed: int = 1, kill_every: float = 60.0) -> dict:
    """Run the soak for ``seconds``; returns its figures (see the module docstring)."""
    rec = recording()
    # ipc endpoints: a restarted daemon is where the senders' sockets reconnect
    d = Served(tmp, checkpoint_interval=2.0)
    load = Load(d, rec, seed, time.monotonic() + seconds)
    runs = []  # per daemon run: frames taken, RSS peak, latency, open streams

    def close_run():
        tot = d.request("stats", timeout=10.0)["totals"]
        runs.append(
            {
                "frames": tot["frames"],
                "rss_mb": d.rss_peak_mb(),
                "p50": tot.get("latency_p50_ms"),
                "p99": tot.get("latency_p99_ms"),
                "streams": tot["streams"],
            }
        )

    deaths, kills = [], 0
    start = time.monotonic()
    load.start()
    next_kill = start + kill_every
    try:
        while time.monotonic() - start < seconds:
            time.sleep(0.2)
            if d.proc.poll() is not None:  # died by itself
                deaths.append(d.proc.returncode)
                d.start()
                continue
            if kill_every and time.monotonic() >= next_kill:
                close_run()
                d.kill()
                kills += 1
                d.start()
                next_kill = time.monotonic() + kill_every
        load.stop()
        close_run()
        time.sleep(1.0)  # the last events reach the log's readers
        missing = missing_from_log(d.ep["control"], numbered(load.seen))
    finally:
        load.stopping.set()
        d.stop()
    return {
        "seconds": round(time.monotonic() - start, 1),
        "kills": kills,
        "deaths": deaths,
        "sent": load.sent,
        "taken": sum(r["frames"] for r in runs),
        "seen_live": len(load.seen),
        "missing_from_log": len(missing),
        "rss_peak_mb": max(r["rss_mb"] for r in runs),
        "streams_max": max(r["streams"] for r in runs),
        "p50_ms": [r["p50"] for r in runs],
        "p99_ms": [r["p99"] for r in runs],
        "load_errors": load.errors,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--kill-every", type=float, default=60.0, help="seconds between SIGKILLs")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        r = run_soak(args.minutes * 60, Path(tmp), args.seed, args.kill_every)
    p99 = [x for x in r["p99_ms"] if x is not None]
    p50 = [x for x in r["p50_ms"] if x is not None]
    rows = [
        ("duration", f"{r['seconds']} s, {r['kills']} SIGKILLs and restarts"),
        ("deaths besides the kills", f"{len(r['deaths'])} {r['deaths'] or ''}".strip()),
        ("frames sent / taken", f"{r['sent']:,} / {r['taken']:,}"),
        ("events seen live missing from the log", f"{r['missing_from_log']} of {r['seen_live']:,}"),
        (
            "RSS peak",
            f"{r['rss_peak_mb']:.0f} MiB (ingest_bytes {INGEST_BYTES >> 20} MiB; "
            f"at most {r['streams_max']} streams open at a kill)",
        ),
        (
            "packet latency p50 / p99 per run",
            f"{', '.join(f'{x:.1f}' for x in p50)} / {', '.join(f'{x:.1f}' for x in p99)} ms",
        ),
        (
            "errors in the load's own threads",
            f"{len(r['load_errors'])} {r['load_errors'][:3] or ''}".strip(),
        ),
    ]
    print("| what | figure |\n|---|---|")
    for k, v in rows:
        print(f"| {k} | {v} |")
    ok = not r["deaths"] and not r["missing_from_log"] and not r["load_errors"]
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
