"""Scale-out on Dask: relabel capacity per backend, ``batch`` speed-up, scheduler overhead.

(a) Relabel capacity, a simulated load (not a full 1,000-stream daemon: on this 2-core
    machine the daemon's own ingest of 1,000 streams would take the cores the workers need):
    J relabel jobs of distinct streams, each the daemon's revision
    (``streamseg.daemon.pipeline.relabel``: HACA, K found) over the default 60 s history of real
    120 Hz features (CMU 86_01 + 14_14 + 14_20, the daemon's 17 cut features), are handed at
    once to the daemon's own relabel workers: the thread backend (``RelabelWorker``, share 1:
    no pause, the best it does) and the dask backend (``DaskRelabelWorker``) on a local
    cluster of 1 and 2 worker processes. Jobs per second, median of ``--repeats``; from it
    the relabel interval each stream gets at S streams, ``max(R, S / jobs_per_s)`` with the
    default cadence R = 5 s.
(b) ``streamseg batch --method lof`` over every recording in data/ (``--copies`` copies of
    it, as links in a temporary folder: 201 recordings, most of them 1-3 s HDM05 clips) and
    ``--method aca`` (HACA, K found) over the 13 CMU takes (``--aca-copies`` copies), on a
    local cluster of 1 and 2 worker processes started beforehand (``--scheduler``): wall
    time of the command and speed-up against 1 worker; the cluster's start on its own.
(c) Scheduler overhead per task: a trivial task's round trip (submit, run, result), one at a
    time, and per task of 1,000 trivial tasks submitted together.

Run: .venv/bin/python benchmarks/scaleout.py [--jobs 8] [--repeats 3] [--copies 3]
     [--aca-copies 6] [--skip a,b,c]
The machine has 2 cores shared with other work: 2 workers can at best double 1 worker, and
any other load on the machine shows in the figures.
"""

from __future__ import annotations

import argparse
import io
import os
import statistics
import sys
import tempfile
import time
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from streamseg.daemon.dask_worker import DaskRelabelWorker  # noqa: E402
from streamseg.daemon.pipeline import Algorithms  # noqa: E402
from streamseg.daemon.worker import RelabelJob, RelabelWorker  # noqa: E402
from streamseg.io import read  # noqa: E402
from streamseg.scaleout import local_cluster  # noqa: E402
from streamseg.skeleton import bone_angles  # noqa: E402

DATA = ROOT / "data"
FPS = 120.0
HISTORY = 60.0
CADENCE = 5.0


def features() -> np.ndarray:
    parts = [read(DATA / "cmu86/86_01.amc.gz", skeleton=DATA / "cmu86/86.asf")]
    parts += [read(DATA / f"cmu_exercise/{n}.amc.gz", skeleton=DATA / "cmu86/86.asf")
              for n in ("14_14", "14_20")]
    a = np.concatenate([bone_angles(r.positions, r.skeleton, inclinations=True)
                        for r in parts])
    return a.astype(np.float32).astype(np.float64)  # as the daemon's float32 ring gives them


def make_jobs(X: np.ndarray, n: int) -> list:
    """``n`` jobs of distinct streams, each 60 s of features from a different offset."""
    m = int(HISTORY * FPS)
    jobs = []
    for i in range(n):
        a = (i * 997) % (X.shape[0] - m)
        jobs.append(RelabelJob((f"s{i}", 1), X[a:a + m].copy(), np.arange(a, a + m), FPS,
                               None))
    return jobs


def drain(worker, jobs) -> float:
    """Seconds from handing ``jobs`` to ``worker`` until every result is back."""
    t = time.perf_counter()
    for j in jobs:
        worker.submit(j)
    got = 0
    while got < len(jobs):
        res = worker.results()
        for _, r in res:
            if isinstance(r, Exception):
                raise r
        got += len(res)
        time.sleep(0.002)  # the daemon's loop polls the same way (10 ms while busy)
    return time.perf_counter() - t


def relabel_capacity(X, n_jobs: int, repeats: int) -> list:
    rows = []
    alg = Algorithms()
    alg.warmup()
    w = RelabelWorker(alg, share=1.0)
    w.start()
    drain(w, make_jobs(X, 2))  # warm
    times = [drain(w, make_jobs(X, n_jobs)) for _ in range(repeats)]
    w.stop()
    rows.append(("thread (in the daemon)", n_jobs / statistics.median(times)))
    for n_workers in (1, 2):
        cluster = local_cluster(n_workers)
        w = DaskRelabelWorker(alg, cluster.scheduler_address)
        w.start()
        assert w.wait_connected(120), "the local cluster did not come up"
        drain(w, make_jobs(X, 2 * n_workers))  # warm every worker
        times = [drain(w, make_jobs(X, n_jobs)) for _ in range(repeats)]
        assert w.fallbacks == 0, "a job fell back to the local backend"
        w.stop()
        cluster.close()
        rows.append((f"dask, local cluster of {n_workers}", n_jobs / statistics.median(times)))
    return rows


def batch_wall(inputs, address: str, out: Path, method: str = "lof") -> tuple:
    from streamseg.cli import main

    if out.exists():
        out.unlink()
    t = time.perf_counter()
    with redirect_stderr(io.StringIO()), redirect_stdout(io.StringIO()):
        rc = main(["batch", *inputs, "--method", method, "--scheduler", address,
                   "--skeleton", str(DATA / "cmu86/86.asf"), "--output", str(out)])
    wall = time.perf_counter() - t
    if rc != 0:
        raise SystemExit(f"batch failed (exit {rc}); see {out}")
    import json

    work = sum(json.loads(line).get("seconds", 0.0) for line in out.read_text().splitlines())
    return wall, work


def batch_speedup(copies: int, repeats: int, method: str, subset=None) -> tuple:
    """``(n recordings, [(workers, median wall s, task s summed)]``) over ``copies`` links
    to data/ (or to its folders ``subset``)."""
    tmp = Path(tempfile.mkdtemp(prefix="streamseg-scaleout-"))
    for c in range(copies):
        os.symlink(DATA, tmp / f"copy{c}")  # the same files under other names
    from streamseg.commands.batch_tasks import expand

    inputs = [str(tmp / f"copy{c}" / sub) for c in range(copies) for sub in (subset or [""])]
    n = len(expand(inputs))
    rows = []
    for workers in (1, 2):
        t = time.perf_counter()
        cluster = local_cluster(workers)
        started = time.perf_counter() - t
        address = cluster.scheduler_address
        batch_wall([str(DATA / "cmu86")], address, tmp / "warm.jsonl", method)  # kernels
        runs = [batch_wall(inputs, address, tmp / "out.jsonl", method) for _ in range(repeats)]
        cluster.close()
        rows.append((workers, statistics.median(w for w, _ in runs),
                     statistics.median(k for _, k in runs), started))
    return n, rows


def _spin(n: int) -> int:
    x = 0
    for i in range(n):
        x += i & 7
    return x


def ceiling(repeats: int) -> float:
    """The machine's own 2-process speed-up right now: 4 equal pure-Python loops on 1 and
    on 2 processes (what any 2-worker figure is bounded by while others use the cores)."""
    import multiprocessing

    ctx = multiprocessing.get_context("spawn")
    walls = {}
    for procs in (1, 2):
        with ctx.Pool(procs) as pool:
            pool.map(_spin, [10] * procs)
            runs = []
            for _ in range(repeats):
                t = time.perf_counter()
                pool.map(_spin, [3_000_000] * 4)
                runs.append(time.perf_counter() - t)
        walls[procs] = statistics.median(runs)
    return walls[1] / walls[2]


def overhead(repeats: int) -> tuple:
    import distributed

    cluster = local_cluster(1)
    client = distributed.Client(cluster, set_as_default=False)
    client.submit(int, 0, pure=False).result()
    trips = []
    for i in range(200):
        t = time.perf_counter()
        client.submit(int, i, pure=False).result()
        trips.append(time.perf_counter() - t)
    bulk = []
    for _ in range(repeats):
        t = time.perf_counter()
        futs = client.map(int, range(1000), pure=False)
        client.gather(futs)
        bulk.append((time.perf_counter() - t) / 1000)
        del futs
    client.close()
    cluster.close()
    return statistics.median(trips), statistics.median(bulk)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=8, help="relabel jobs per timed run")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--copies", type=int, default=3, help="copies of data/ for (b)")
    ap.add_argument("--aca-copies", type=int, default=6,
                    help="copies of the 13 CMU takes for (b), aca")
    ap.add_argument("--skip", default="", help="comma list of a,b,c to skip")
    args = ap.parse_args()
    skip = set(args.skip.split(","))
    print(f"{os.cpu_count()} cores (shared with other work); median of {args.repeats} runs; "
          f"the machine's 2-process speed-up on a pure-Python loop now: "
          f"{ceiling(args.repeats):.2f}x\n")
    if "a" not in skip:
        X = features()
        rows = relabel_capacity(X, args.jobs, args.repeats)
        base = rows[0][1]
        print(f"(a) relabel capacity, simulated load: {args.jobs} jobs of 60 s of 120 Hz "
              f"features at once (revision = HACA, K found); interval per stream = max({CADENCE:g}"
              " s, S / jobs per s)")
        print("| backend | jobs/s | vs thread | interval at 100 streams s | at 1,000 streams s |")
        print("|---|---|---|---|---|")
        for name, rate in rows:
            print(f"| {name} | {rate:.2f} | {rate / base:.2f}x | {max(CADENCE, 100 / rate):.0f} "
                  f"| {max(CADENCE, 1000 / rate):.0f} |", flush=True)
        print()
    if "b" not in skip:
        print("(b) streamseg batch --scheduler (a local cluster started beforehand: its start "
              "is its own column); wall time of the command; 'segment s' sums the seconds of "
              "the lines (lof: the whole task; aca: the fit, without reading)")
        print("| method | recordings | workers | cluster start s | wall s | segment s (sum) | "
              "recordings/s | speed-up |")
        print("|---|---|---|---|---|---|---|---|")
        cmu = ["cmu86", "cmu_exercise", "cmu02"]  # the 13 CMU takes: 1.4-38 s each
        for method, copies, subset, what in (
                ("lof", args.copies, None, "data/"), ("aca", args.aca_copies, cmu, "CMU takes")):
            if copies <= 0:
                continue
            n, rows = batch_speedup(copies, args.repeats, method, subset)
            for workers, wall, work, started in rows:
                print(f"| {method} | {n} ({copies} x {what}) | {workers} | {started:.1f} | "
                      f"{wall:.1f} | {work:.1f} | {n / wall:.1f} | {rows[0][1] / wall:.2f}x |",
                      flush=True)
        print()
    if "c" not in skip:
        trip, bulk = overhead(args.repeats)
        print("(c) scheduler overhead per task (local cluster of 1 worker process)")
        print("| measure | ms per task |")
        print("|---|---|")
        print(f"| trivial task round trip, one at a time (median of 200) | {trip * 1e3:.2f} |")
        print(f"| 1,000 trivial tasks submitted together, per task | {bulk * 1e3:.3f} |")
    print(f"\nthe machine's 2-process speed-up on the pure-Python loop at the end: "
          f"{ceiling(args.repeats):.2f}x")


if __name__ == "__main__":
    main()
