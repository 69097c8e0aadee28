"""What the speed benchmarks share: data, timing, a daemon in this process, sender processes.

Every figure is measured here on this machine's own run: ratios against a baseline measured
in the same run where one exists, medians of several runs.
"""

from __future__ import annotations

import functools
import multiprocessing as mp
import statistics
import sys
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
# spawned sender processes unpickle their target as suite._harness.<name>: they inherit sys.path
if str(Path(__file__).resolve().parents[1]) not in sys.path:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
DATA = ROOT / "data"
PLACEHOLDER = "sXXXXXXX"  # stream id replaced per stream in pre-encoded packets


@functools.cache
def recording():
    """CMU 86_01 (4,579 frames, 120 Hz) with its skeleton."""
    from streamseg.io import read

    return read(DATA / "cmu86" / "86_01.amc.gz", skeleton=DATA / "cmu86" / "86.asf")


def median_time(fn, runs: int) -> float:
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def rss_kb() -> int:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS in /proc/self/status")


def start_daemon(**overrides):
    """A daemon on free loopback ports, running in a thread of this process."""
    import logging

    from streamseg.config import DaemonConfig
    from streamseg.daemon import Daemon

    logging.getLogger("streamseg").setLevel(logging.ERROR)  # 1,000 streams' notices, no table
    loop = "tcp://127.0.0.1:0"
    cfg = dict(ingest=loop, publish=loop, control="", heartbeat=0)
    cfg.update(overrides)
    d = Daemon(DaemonConfig(**cfg))
    ep = d.bind()
    t = threading.Thread(target=d.run, daemon=True)
    t.start()
    d.ready.wait()
    return d, ep, t


def stop_daemon(d, t) -> None:
    d.stop()
    t.join()


def encoded_stream(n_frames: int, batch: int, stream: str = "bench") -> list:
    """Announce, frame packets of 86_01 cycled to ``n_frames``, end: ``[topic, body]`` each."""
    from streamseg import protocol as P
    from streamseg.commands.replay import announce_of

    rec = recording()
    idx = np.arange(n_frames) % rec.n_frames
    msgs = [P.encode(announce_of(rec, stream))]
    msgs += [
        P.encode(P.Frames(stream, a, 0.0, rec.positions[idx[a : a + batch]]))
        for a in range(0, n_frames, batch)
    ]
    msgs.append(P.encode(P.End(stream)))
    return msgs


def _burst(endpoint, msgs, go):
    import zmq

    ctx = zmq.Context()
    s = ctx.socket(zmq.PUSH)
    s.setsockopt(zmq.SNDHWM, 200_000)
    s.setsockopt(zmq.LINGER, -1)
    s.connect(endpoint)
    go.wait()
    for m in msgs:
        s.send_multipart(m, copy=False)
    s.close()
    ctx.term()


def spawn(target, *args):
    """A spawned process running ``target(*args, go)``, connected and waiting for ``go``."""
    ctx = mp.get_context("spawn")
    go = ctx.Event()
    p = ctx.Process(target=target, args=(*args, go))
    p.start()
    time.sleep(1.5)  # interpreter start and connect, before any clock starts
    return p, go


def raw_seconds(msgs) -> float:
    """A bare PULL + msgpack.unpackb loop taking ``msgs`` from a sender process."""
    import msgpack
    import zmq

    from streamseg.config import DaemonConfig

    ctx = zmq.Context()
    pull = ctx.socket(zmq.PULL)
    pull.setsockopt(zmq.RCVHWM, DaemonConfig().ingest_hwm)  # as the daemon's ingest
    port = pull.bind_to_random_port("tcp://127.0.0.1")
    p, go = spawn(_burst, f"tcp://127.0.0.1:{port}", msgs)
    go.set()
    t0 = time.perf_counter()
    for _ in range(len(msgs)):
        parts = pull.recv_multipart()
        msgpack.unpackb(parts[1], raw=False)
    dt = time.perf_counter() - t0
    p.join()
    pull.close()
    ctx.term()
    return dt


def daemon_seconds(msgs, n_frames: int) -> float:
    """The daemon (cut detector, relabelling off) taking ``msgs``: until the last frame is
    processed and the stream closed."""
    d, ep, t = start_daemon(relabel_interval=0.0)
    p, go = spawn(_burst, ep["ingest"], msgs)
    go.set()
    t0 = time.perf_counter()
    limit = t0 + 300
    while (d.n_frames < n_frames or d.streams) and time.perf_counter() < limit:
        time.sleep(0.001)
    dt = time.perf_counter() - t0
    taken = d.n_frames
    p.join()
    stop_daemon(d, t)
    if taken < n_frames:
        raise RuntimeError(f"the daemon took {taken} of {n_frames} frames")
    return dt


def _live(endpoint, templates, announce, n_streams, batch, fps, seconds, preload, go):
    """``n_streams`` streams of 120 Hz frames, each on its own clock (starts staggered over
    1 s); each starts ``preload`` seconds into its recording, sent at once (a full history)."""
    import zmq

    from streamseg import protocol as P

    ctx = zmq.Context()
    s = ctx.socket(zmq.PUSH)
    s.setsockopt(zmq.SNDHWM, 2_000_000)
    s.setsockopt(zmq.LINGER, 2000)
    s.connect(endpoint)
    ids = [f"s{k:07d}".encode() for k in range(n_streams)]
    ph = PLACEHOLDER.encode()
    go.wait()
    for sid in ids:
        s.send_multipart([b"announce/" + sid + b"/", announce.replace(ph, sid)])
    t0 = time.perf_counter()
    offset = np.linspace(0, 1.0, n_streams, endpoint=False) - preload
    sent = np.zeros(n_streams, dtype=np.int64)
    period = batch / fps
    while time.perf_counter() - t0 < seconds:
        now = time.perf_counter() - t0
        due = np.minimum(
            np.maximum(((now - offset) // period).astype(np.int64) + 1, 0), len(templates)
        )
        for k in np.flatnonzero(due > sent):
            sid = ids[k]
            for i in range(sent[k], due[k]):
                s.send_multipart([b"frames/" + sid + b"/", templates[i].replace(ph, sid)])
            sent[k] = due[k]
        time.sleep(0.002)
    for sid in ids:
        s.send_multipart([b"end/" + sid + b"/", P.encode(P.End(sid.decode()))[1]])
    s.close()
    ctx.term()


def live_run(
    n_streams: int,
    seconds: float,
    *,
    batch: int = 4,
    preload: float = 0.0,
    settle: float = 2.0,
    **overrides,
) -> dict:
    """``n_streams`` real-time 120 Hz streams of 86_01 (repeated) into a daemon with
    ``overrides``; measured after ``settle`` s (and the preload) for the rest of ``seconds``.

    Returns offered and taken frames/s, packet latency p50/p99 (s) and relabels/s.
    """
    from streamseg import protocol as P
    from streamseg.commands.replay import announce_of

    rec = recording()
    reps = int(np.ceil((seconds + preload + 2) * rec.fps / rec.n_frames))
    pos = np.concatenate([rec.positions] * reps)
    tmpl = [
        P.encode(P.Frames(PLACEHOLDER, a, 0.0, pos[a : a + batch]))[1]
        for a in range(0, pos.shape[0], batch)
    ]
    announce = P.encode(announce_of(rec, PLACEHOLDER))[1]
    d, ep, t = start_daemon(max_streams=n_streams + 10, max_streams_per_client=0, **overrides)
    p, go = spawn(
        _live, ep["ingest"], tmpl, announce, n_streams, batch, rec.fps, seconds + preload, preload
    )
    go.set()
    start = time.perf_counter()
    if preload:  # the histories first: wait until every stream holds them
        want = n_streams * preload * rec.fps * 0.98
        while d.n_frames < want and time.perf_counter() - start < seconds + preload:
            time.sleep(0.05)
    time.sleep(settle)
    f0, r0 = d.n_frames, d.totals["relabels"]
    d.intake.latency.reset()
    t0 = time.perf_counter()
    time.sleep(max(start + preload + seconds - 0.5 - t0, 1.0))
    dt = time.perf_counter() - t0
    f1, r1 = d.n_frames, d.totals["relabels"]
    p50, p99 = d.intake.latency.percentiles()
    p.join()
    stop_daemon(d, t)
    return {
        "offered": n_streams * rec.fps,
        "taken": (f1 - f0) / dt,
        "p50": p50,
        "p99": p99,
        "relabels": (r1 - r0) / dt,
    }
