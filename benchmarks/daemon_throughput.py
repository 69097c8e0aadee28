"""Daemon throughput, latency and capacity, beside the raw ZeroMQ + msgpack limit.

Run: ``.venv/bin/python benchmarks/daemon_throughput.py [--frames 60000] [--repeats 3]
[--streams 250,500,1000] [--stream-batch 4] [--seconds 6] [--relabel-backend dask
--dask-workers 2]``

1. Frames per second, one stream sent as fast as possible by a separate sender process, with
   1 and with 120 frames per packet: (a) the raw limit, a bare ``recv_multipart`` +
   ``msgpack.unpackb`` loop on the same packets from the same sender; (b) the pipeline alone
   (bone angles + streaming LOF on the same frames, no sockets), the algorithm's own limit;
   (c) the daemon (LOF cuts; relabelling off, then on). Median of ``--repeats`` runs.
   Latency is the daemon's own measure: a packet's arrival (``recv`` returned) to the
   publication of its events (its pipeline step done), p50/p99 over all packets of a run.
2. Capacity: S streams of CMU 86_01 at real time (120 Hz, ``--stream-batch`` frames per
   packet, starts staggered over 1 s; the recording repeated when a row lasts longer than
   it), relabelling on; for each S the received and offered
   frame rates, packet latency p50/p99, relabels per second, and the share of one core the
   event log and checkpoints took (``durability CPU %``). A count is "sustained" when the
   daemon takes >= 98% of the offered frames and p99 latency stays < 100 ms.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import statistics
import threading
import time
from pathlib import Path

import msgpack
import numpy as np
import zmq

from streamseg import protocol as P
from streamseg.commands.replay import announce_of
from streamseg.config import DaemonConfig
from streamseg.daemon import Daemon
from streamseg.io import read

DATA = Path(__file__).resolve().parents[1] / "data" / "cmu86"
ID = b"sXXXXXXX"  # placeholder stream id replaced per stream in pre-encoded bodies


def load():
    return read(DATA / "86_01.amc.gz", skeleton=DATA / "86.asf")


def encoded_stream(rec, n_frames: int, batch: int, stream: str = "bench"):
    """Announce, frame packets covering ``n_frames`` (recording cycled), end: [topic, body]s."""
    pos = rec.positions
    idx = np.arange(n_frames) % rec.n_frames
    msgs = [P.encode(announce_of(rec, stream))]
    for a in range(0, n_frames, batch):
        msgs.append(P.encode(P.Frames(stream, a, 0.0, pos[idx[a:a + batch]])))
    msgs.append(P.encode(P.End(stream)))
    return msgs


def sender(endpoint, msgs, go, hwm):
    ctx = zmq.Context()
    s = ctx.socket(zmq.PUSH)
    s.setsockopt(zmq.SNDHWM, hwm)
    s.setsockopt(zmq.LINGER, -1)
    s.connect(endpoint)
    go.wait()
    for m in msgs:
        s.send_multipart(m, copy=False)
    s.close()
    ctx.term()


def start_sender(endpoint, msgs, hwm=200000):
    ctx = mp.get_context("spawn")
    go = ctx.Event()
    p = ctx.Process(target=sender, args=(endpoint, msgs, go, hwm))
    p.start()
    time.sleep(1.5)  # interpreter start and connect, before the clock starts
    return p, go


def raw_limit(msgs) -> float:
    """Seconds for a bare PULL + unpackb loop to take ``msgs``."""
    ctx = zmq.Context()
    pull = ctx.socket(zmq.PULL)
    pull.setsockopt(zmq.RCVHWM, DaemonConfig().ingest_hwm)  # as the daemon's ingest
    port = pull.bind_to_random_port("tcp://127.0.0.1")
    p, go = start_sender(f"tcp://127.0.0.1:{port}", msgs)
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


RELABEL_PROCESSES = 0
RELABEL_BACKEND = {}  # relabel_backend / relabel_scheduler overrides (--relabel-backend)
RECEIVE_THREAD = DaemonConfig().receive_thread


def start_daemon(**overrides):
    loop = "tcp://127.0.0.1:0"
    cfg = dict(ingest=loop, publish=loop, control="", heartbeat=0,
               relabel_processes=RELABEL_PROCESSES, receive_thread=RECEIVE_THREAD,
               **RELABEL_BACKEND)
    cfg.update(overrides)
    d = Daemon(DaemonConfig(**cfg))
    ep = d.bind()
    t = threading.Thread(target=d.run, daemon=True)
    t.start()
    d.ready.wait()
    if hasattr(d.worker, "wait_connected"):  # the dask backend: its cluster is up first
        assert d.worker.wait_connected(120), "the Dask cluster did not come up"
    return d, ep, t


def daemon_run(msgs, n_frames, relabel=True, **overrides) -> tuple:
    """(seconds until the last frame was processed, p50, p99 latency) for one stream."""
    d, ep, t = start_daemon(relabel_interval=5.0 if relabel else 0.0, **overrides)
    p, go = start_sender(ep["ingest"], msgs)
    d.latency.reset()
    go.set()
    t0 = time.perf_counter()
    limit = time.perf_counter() + 300
    while (d.n_frames < n_frames or d.streams) and time.perf_counter() < limit:
        time.sleep(0.002)
    if d.n_frames < n_frames:
        raise RuntimeError(f"daemon took {d.n_frames} of {n_frames} frames: {d._totals()}")
    dt = time.perf_counter() - t0
    p50, p99 = d.latency.percentiles()
    p.join()
    d.stop()
    t.join()
    return dt, p50, p99


def algorithm_only(rec, n_frames) -> float:
    """Seconds for the pipeline alone (angles + LOF, no sockets) on the same frames."""
    from streamseg.daemon.pipeline import Algorithms, StreamPipeline

    idx = np.arange(n_frames) % rec.n_frames
    pos = rec.positions[idx]
    p = StreamPipeline(rec.skeleton, rec.fps, Algorithms(), 20.0)
    t0 = time.perf_counter()
    for a in range(0, n_frames, 2000):
        p.push(pos[a:a + 2000], a)
    return time.perf_counter() - t0


def throughput(rec, n_frames, repeats, relabel):
    rows = []
    algo = n_frames / statistics.median(algorithm_only(rec, n_frames) for _ in range(repeats))
    for batch in (1, 120):
        msgs = encoded_stream(rec, n_frames, batch)
        raw = [raw_limit(msgs) for _ in range(repeats)]
        runs = [daemon_run(msgs, n_frames, relabel) for _ in range(repeats)]
        raw_fps = n_frames / statistics.median(raw)
        d_fps = n_frames / statistics.median(r[0] for r in runs)
        rows.append((batch, raw_fps, d_fps, statistics.median(r[1] for r in runs),
                     statistics.median(r[2] for r in runs)))
    print(f"\n1 stream, {n_frames} frames (86_01 cycled), median of {repeats} runs, relabel "
          f"{'every 5 s over 20 s' if relabel else 'off'}")
    print(f"pipeline alone (angles + streaming LOF, 2000-frame chunks, no sockets): "
          f"{algo:,.0f} frames/s")
    print(f"{'frames/packet':>13} {'raw frames/s':>13} {'daemon frames/s':>16} {'/raw':>6} "
          f"{'/min(raw,pipeline)':>19} {'p50 ms':>8} {'p99 ms':>8}")
    for batch, raw_fps, d_fps, p50, p99 in rows:
        print(f"{batch:>13} {raw_fps:>13,.0f} {d_fps:>16,.0f} {d_fps / raw_fps:>6.2f} "
              f"{d_fps / min(raw_fps, algo):>19.2f} {p50 * 1e3:>8.2f} {p99 * 1e3:>8.2f}")


def event_log_cost(rec, n_frames, repeats):
    """Daemon frames/s with the event log and checkpoints off and on, runs interleaved (the
    order alternating)."""
    import tempfile

    print(f"\nevent log + checkpoints off vs on (state_dir), 1 stream, {n_frames} frames, "
          f"relabel every 5 s, median of {repeats} interleaved runs each")
    print(f"{'frames/packet':>13} {'off frames/s':>13} {'on frames/s':>12} {'on/off':>7} "
          f"{'off p99 ms':>11} {'on p99 ms':>10}")
    for batch in (1, 120):
        msgs = encoded_stream(rec, n_frames, batch)
        off, on = [], []
        for k in range(repeats):  # alternate which goes first (the first run of a pair
            for on_now in ((False, True) if k % 2 == 0 else (True, False)):  # is often slower)
                if on_now:
                    with tempfile.TemporaryDirectory() as state:
                        on.append(daemon_run(msgs, n_frames, True, state_dir=state))
                else:
                    off.append(daemon_run(msgs, n_frames, True))
        f_off = n_frames / statistics.median(r[0] for r in off)
        f_on = n_frames / statistics.median(r[0] for r in on)
        print(f"{batch:>13} {f_off:>13,.0f} {f_on:>12,.0f} {f_on / f_off:>7.3f} "
              f"{statistics.median(r[2] for r in off) * 1e3:>11.2f} "
              f"{statistics.median(r[2] for r in on) * 1e3:>10.2f}")


def live_sender(endpoint, templates, announce, n_streams, batch, fps, seconds, go, stats):
    """S real-time streams: each sends the recording's packets on its own 120 Hz clock."""
    ctx = zmq.Context()
    s = ctx.socket(zmq.PUSH)
    s.setsockopt(zmq.SNDHWM, 1_000_000)
    s.setsockopt(zmq.LINGER, 2000)
    s.connect(endpoint)
    ids = [f"s{k:07d}".encode() for k in range(n_streams)]
    go.wait()
    for sid in ids:
        s.send_multipart([b"announce/" + sid + b"/", announce.replace(ID, sid)])
    t0 = time.perf_counter()
    offset = np.linspace(0, 1.0, n_streams, endpoint=False)  # staggered starts
    sent = np.zeros(n_streams, dtype=np.int64)  # packets sent per stream
    period = batch / fps
    total = 0
    while True:
        now = time.perf_counter() - t0
        if now > seconds:
            break
        due = np.maximum(((now - offset) // period).astype(np.int64) + 1, 0)
        due = np.minimum(due, len(templates))
        for k in np.flatnonzero(due > sent):
            sid = ids[k]
            for i in range(sent[k], due[k]):
                s.send_multipart([b"frames/" + sid + b"/", templates[i].replace(ID, sid)])
                total += 1
            sent[k] = due[k]
        time.sleep(0.002)
    for sid in ids:
        s.send_multipart([b"end/" + sid + b"/", P.encode(P.End(sid.decode()))[1]])
    stats.value = total
    s.close()
    ctx.term()


def capacity(rec, counts, batch, seconds, state_dir=False, repeats=1):
    print(f"\n{seconds:g} s per run (the last {seconds - 2.5:g} s measured); 120 Hz streams of "
          f"CMU 86_01, {batch} frames/packet, relabel every {DaemonConfig().relabel_interval:g} s "
          f"over {DaemonConfig().relabel_history:g} s (defaults); median of {repeats} run(s)"
          + ("; the event log + checkpoints off and on, runs interleaved (the order "
             "alternating)" if state_dir else ""))
    print(f"{'streams':>8} {'offered f/s':>12} {'taken f/s':>10} {'p50 ms':>8} {'p99 ms':>8} "
          f"{'relabels/s':>10} {'s between relabels/stream':>26} {'sustained':>9} "
          f"{'durability CPU %':>16}")
    placeholder = ID.decode()
    # the recording repeated (an abrupt join) so that no stream ends before the row does
    reps = int(np.ceil((seconds + 2) * rec.fps / rec.n_frames))
    pos = np.concatenate([rec.positions] * reps)
    tmpl = [P.encode(P.Frames(placeholder, a, 0.0, pos[a:a + batch]))[1]
            for a in range(0, pos.shape[0], batch)]
    announce = P.encode(announce_of(rec, placeholder))[1]
    for n in counts:
        runs = {False: [], True: []}
        for k in range(repeats):
            for on in (((False, True) if k % 2 == 0 else (True, False)) if state_dir
                       else (False,)):
                runs[on].append(capacity_run(rec, tmpl, announce, n, batch, seconds, on,
                                             max(counts) + 10))
        for on in ((False, True) if state_dir else (False,)):
            taken, p50, p99, rel, cpu = (statistics.median(r[i] for r in runs[on])
                                         for i in range(5))
            offered = n * rec.fps
            ok = taken >= 0.98 * offered and p99 < 0.1
            print(f"{n:>8} {offered:>12,.0f} {taken:>10,.0f} {p50 * 1e3:>8.2f} "
                  f"{p99 * 1e3:>8.2f} {rel:>10.2f} {n / rel if rel else float('inf'):>26.1f} "
                  f"{'yes' if ok else 'NO':>9} {100 * cpu:>16.1f}"
                  + ((" log on" if on else " log off") if state_dir else ""))
        if state_dir:
            med = {on: [statistics.median(r[i] for r in runs[on]) for i in range(4)]
                   for on in runs}
            ratio = [a / b if b else float("nan") for a, b in zip(med[True][:4], med[False][:4])]
            print(f"{'':>8} on/off: taken {ratio[0]:.3f}, relabels/s {ratio[3]:.3f}, "
                  f"p50 {ratio[1]:.3f}, p99 {ratio[2]:.3f}")
            if repeats > 1:
                # run k "on" against run k "off" (run back to back): the spread between pairs
                # says how far the medians' ratio above can be trusted on this machine
                pairs = [[r_on[i] / r_off[i] if r_off[i] else float("nan") for i in range(4)]
                         for r_on, r_off in zip(runs[True], runs[False])]
                for name, i in (("taken", 0), ("relabels/s", 3), ("p50", 1), ("p99", 2)):
                    vals = sorted(p[i] for p in pairs)
                    print(f"{'':>8} paired on/off {name}: median {statistics.median(vals):.3f}, "
                          f"range {vals[0]:.3f}-{vals[-1]:.3f} over {len(vals)} pairs")
                for on in (False, True):
                    p50s = sorted(r[1] * 1e3 for r in runs[on])
                    print(f"{'':>8} p50 ms per run, log {'on' if on else 'off'}: "
                          + " ".join(f"{v:.2f}" for v in p50s))


def capacity_run(rec, tmpl, announce, n, batch, seconds, on, max_streams):
    """(taken frames/s, p50 s, p99 s, relabels/s, durability CPU s/s) of one run of ``n``
    real-time streams."""
    import tempfile

    tmp = tempfile.TemporaryDirectory() if on else None
    d, ep, t = start_daemon(max_streams=max_streams, max_streams_per_client=0,
                            **({"state_dir": tmp.name} if on else {}))
    ctx = mp.get_context("spawn")
    go, total = ctx.Event(), ctx.Value("q", 0)
    p = ctx.Process(target=live_sender, args=(ep["ingest"], tmpl, announce, n, batch,
                                              rec.fps, seconds, go, total))
    p.start()
    time.sleep(1.5)
    go.set()
    time.sleep(2.0)  # all streams started and the buffers filling
    f0, r0, c0 = d.n_frames, d.totals["relabels"], durability_cpu(d)
    d.latency.reset()
    t0 = time.perf_counter()
    time.sleep(seconds - 2.5)
    dt = time.perf_counter() - t0
    f1, r1, c1 = d.n_frames, d.totals["relabels"], durability_cpu(d)
    p50, p99 = d.latency.percentiles()
    p.join()
    d.stop()
    t.join()
    if tmp is not None:
        tmp.cleanup()
    nan = float("nan")
    return ((f1 - f0) / dt, nan if p50 is None else p50, nan if p99 is None else p99,
            (r1 - r0) / dt, (c1 - c0) / dt)


def durability_cpu(d) -> float:
    """Seconds the daemon has spent on durability: the loop's time copying states and the
    checkpoint and event-log writer threads' own CPU time (not their pauses; little
    affected by other load on the machine)."""
    return (d.checkpoint_seconds
            + (d.checkpoints.cpu_seconds if d.checkpoints is not None else 0.0)
            + (d.eventlog.cpu_seconds if d.eventlog is not None else 0.0))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=60000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--streams", default="250,500,1000")
    ap.add_argument("--stream-batch", type=int, default=4)
    ap.add_argument("--seconds", type=float, default=6.0)
    ap.add_argument("--skip-throughput", action="store_true")
    ap.add_argument("--capacity-repeats", type=int, default=1,
                    help="runs per stream count (interleaved off/on with --event-log)")
    ap.add_argument("--event-log", action="store_true",
                    help="only compare the event log and checkpoints off and on")
    ap.add_argument("--relabel-processes", type=int, default=0,
                    help="DaemonConfig.relabel_processes (0: relabel in a thread)")
    ap.add_argument("--relabel-backend", choices=("thread", "process", "dask"), default=None,
                    help="DaemonConfig.relabel_backend (default: the config's default)")
    ap.add_argument("--dask-workers", type=int, default=0,
                    help="with --relabel-backend dask: a local cluster of this many worker "
                         "processes, started here (0: the daemon starts one per core)")
    ap.add_argument("--receive-thread", type=int, choices=(0, 1), default=None,
                    help="DaemonConfig.receive_thread (default: the config's default)")
    ap.add_argument("--switch-interval", type=float, default=0.0,
                    help="sys.setswitchinterval for this process (0: leave Python's 5 ms)")
    args = ap.parse_args()
    global RELABEL_PROCESSES, RECEIVE_THREAD
    RELABEL_PROCESSES = args.relabel_processes
    if args.receive_thread is not None:
        RECEIVE_THREAD = bool(args.receive_thread)
    if args.switch_interval:
        import sys

        sys.setswitchinterval(args.switch_interval)
    cluster = None
    if args.relabel_backend:
        RELABEL_BACKEND["relabel_backend"] = args.relabel_backend
        if args.relabel_backend == "dask" and args.dask_workers:
            from streamseg.scaleout import local_cluster

            cluster = local_cluster(args.dask_workers)
            RELABEL_BACKEND["relabel_scheduler"] = cluster.scheduler_address
    print(f"relabel_processes = {RELABEL_PROCESSES}, receive_thread = {RECEIVE_THREAD}, "
          f"relabel backend {RELABEL_BACKEND or 'thread'}"
          + (f" ({args.dask_workers} local workers)" if cluster else ""))
    rec = load()
    if args.event_log:
        event_log_cost(rec, args.frames, args.repeats)
        if args.streams:
            capacity(rec, [int(x) for x in args.streams.split(",")], args.stream_batch,
                     args.seconds, state_dir=True, repeats=args.capacity_repeats)
        return
    if not args.skip_throughput:
        for relabel in (False, True):
            throughput(rec, args.frames, args.repeats, relabel)
    if args.streams:
        capacity(rec, [int(x) for x in args.streams.split(",")], args.stream_batch, args.seconds,
                 repeats=args.capacity_repeats)
    if cluster is not None:
        cluster.close()


if __name__ == "__main__":
    main()
