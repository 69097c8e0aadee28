"""The daemon: ingest against the raw socket loop, streams sustained, relabel cadence, memory.

Ingest: one stream of 86_01 sent as fast as a separate process can, 1 and 120 frames per
packet, relabelling off; the daemon's frames/s over a bare ``recv_multipart`` +
``msgpack.unpackb`` loop on the same packets (the raw limit), both medians of 3 runs in this
process. Capacity: real-time 120 Hz streams (4 frames per packet) with the default
relabelling; sustained when >= 98 % of the offered frames are taken and the packet latency
p99 stays under 100 ms. Relabel cadence: 500 such streams, each starting with a full 60 s
history, relabels in 2 niced processes (``relabel_backend = "process"``): seconds between two
revisions of one stream = streams / revisions per second. Durability: 100 such streams with
the event log and checkpoints (``state_dir``) against without, taken frames and packet
latency p99 as ratios in the same run. Soak: 1 million frames of 10 streams at a time (4
rounds, each stream announced and ended, 60 frames per packet, as fast as the daemon takes
them, relabelling on): resident memory at the end minus at half-way (flat: a few MB).
Idle: resident memory of 1,000 streams announced and not sending, per stream.
"""

from __future__ import annotations

import statistics

from ._harness import (
    daemon_seconds,
    encoded_stream,
    live_run,
    raw_seconds,
    rss_kb,
    start_daemon,
    stop_daemon,
)

FRAMES = {1: 60_000, 120: 240_000}


class Ingest:
    params = [1, 120]
    param_names = ["frames_per_packet"]
    timeout = 600
    number = repeat = rounds = 1

    def setup_cache(self):
        out = {}
        for batch, n in FRAMES.items():
            msgs = encoded_stream(n, batch)
            raw = statistics.median(raw_seconds(msgs) for _ in range(3))
            daemon = statistics.median(daemon_seconds(msgs, n) for _ in range(3))
            out[batch] = {"raw": n / raw, "daemon": n / daemon}
        return out

    def track_daemon_over_raw(self, cache, batch):
        return cache[batch]["daemon"] / cache[batch]["raw"]

    track_daemon_over_raw.unit = "x raw"

    def track_daemon_frames_per_s(self, cache, batch):
        return cache[batch]["daemon"]

    track_daemon_frames_per_s.unit = "frames/s"

    def track_raw_frames_per_s(self, cache, batch):
        return cache[batch]["raw"]

    track_raw_frames_per_s.unit = "frames/s"


class Streams:
    timeout = 600
    number = repeat = rounds = 1

    def setup_cache(self):
        return live_run(1000, 20.0)

    def track_1000_taken(self, run):
        return run["taken"] / run["offered"]

    track_1000_taken.unit = "of offered"

    def track_1000_p99_ms(self, run):
        return run["p99"] * 1e3

    track_1000_p99_ms.unit = "ms"


class Cadence:
    timeout = 900
    number = repeat = rounds = 1

    def setup_cache(self):
        return live_run(
            500, 40.0, preload=60.0, settle=5.0, relabel_backend="process", relabel_processes=2
        )

    def track_500_seconds_between_relabels(self, run):
        return 500 / run["relabels"] if run["relabels"] else float("inf")

    track_500_seconds_between_relabels.unit = "s"

    def track_500_taken(self, run):
        return run["taken"] / run["offered"]

    track_500_taken.unit = "of offered"


class Durability:
    timeout = 600
    number = repeat = rounds = 1

    def setup_cache(self):
        import tempfile

        off = live_run(100, 15.0)
        with tempfile.TemporaryDirectory() as state:
            on = live_run(100, 15.0, state_dir=state)
        return {"taken": on["taken"] / off["taken"], "p99": on["p99"] / off["p99"]}

    def track_100_taken_on_over_off(self, r):
        return r["taken"]

    track_100_taken_on_over_off.unit = "of offered"

    def track_100_p99_on_over_off(self, r):
        return r["p99"]

    track_100_p99_on_over_off.unit = "x"


def _soak_sender(endpoint, per_stream, n_streams, rounds, batch, go):
    import numpy as np
    import zmq

    from streamseg import protocol as P
    from streamseg.commands.replay import announce_of

    from ._harness import recording

    rec = recording()
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
            for name, off in zip(names, offsets, strict=True):
                idx = (off + a + np.arange(batch)) % rec.n_frames
                s.send_multipart(P.encode(P.Frames(name, a, 0.0, rec.positions[idx])))
        for name in names:
            s.send_multipart(P.encode(P.End(name)))
    s.close()
    ctx.term()


def track_soak_rss_growth_mb():
    import time

    from ._harness import spawn

    streams, rounds, batch = 10, 4, 60
    per_stream = 1_000_000 // (streams * rounds) // batch * batch
    total = per_stream * streams * rounds
    d, ep, t = start_daemon(heartbeat=1.0)
    p, go = spawn(_soak_sender, ep["ingest"], per_stream, streams, rounds, batch)
    go.set()
    half = None
    start = time.perf_counter()
    while (d.n_frames < total or d.streams or d.closing) and time.perf_counter() - start < 600:
        if half is None and d.n_frames >= total // 2:
            half = rss_kb()
        time.sleep(0.05)
    end = rss_kb()
    p.join()
    stop_daemon(d, t)
    return (end - half) / 1024


track_soak_rss_growth_mb.unit = "MB"
track_soak_rss_growth_mb.timeout = 900


def track_idle_kb_per_stream():
    """Resident memory of 1,000 announced streams that sent no frame, per stream."""
    import zmq

    from streamseg import protocol as P
    from streamseg.commands.replay import announce_of

    from ._harness import recording

    d, ep, t = start_daemon(
        max_streams=2000, max_streams_per_client=0, relabel_interval=0.0, idle_timeout=3600.0
    )
    ctx = zmq.Context()
    s = ctx.socket(zmq.PUSH)
    s.connect(ep["ingest"])
    rec = recording()
    import time

    time.sleep(0.5)
    before = rss_kb()
    for k in range(1000):
        s.send_multipart(P.encode(announce_of(rec, f"idle{k:04d}")))
    while len(d.streams) < 1000:
        time.sleep(0.01)
    time.sleep(0.5)
    after = rss_kb()
    s.close()
    ctx.term()
    stop_daemon(d, t)
    return (after - before) / 1000


track_idle_kb_per_stream.unit = "kB"
track_idle_kb_per_stream.timeout = 300
