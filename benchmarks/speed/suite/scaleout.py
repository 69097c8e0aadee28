"""Relabel capacity per backend, the figure ``docs/scaling.md``'s cost model starts from.

Eight relabel jobs of distinct streams, each the daemon's revision
(``streamseg.daemon.relabel_job.relabel``: HACA, K found) over a 60 s window of real 120 Hz
features (86_01, 14_14, 14_20 joined, float32 as the daemon keeps them), handed at once to
the daemon's own relabel workers: the thread backend (share 1: the best it does), the process
backend with 2 processes, and the dask backend on a local cluster of 2 worker processes
(:func:`streamseg.scaleout.local_cluster`). Jobs per second, median of 3; and the scheduler's
overhead per task when 1,000 trivial tasks go together.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from ._harness import DATA

JOBS = 8


def _features():
    from streamseg.io import read
    from streamseg.skeleton import bone_angles

    asf = DATA / "cmu86" / "86.asf"
    parts = [read(DATA / "cmu86" / "86_01.amc.gz", skeleton=asf)]
    parts += [read(DATA / "cmu_exercise" / f"{n}.amc.gz", skeleton=asf) for n in ("14_14", "14_20")]
    a = np.concatenate([bone_angles(r.positions, r.skeleton, inclinations=True) for r in parts])
    return a.astype(np.float32).astype(np.float64)


def _jobs(X, n):
    from streamseg.daemon.worker import RelabelJob

    m = 7200
    out = []
    for i in range(n):
        a = (i * 997) % (X.shape[0] - m)
        out.append(RelabelJob((f"s{i}", 1), X[a : a + m].copy(), np.arange(a, a + m), 120.0, None))
    return out


def _drain(worker, jobs) -> float:
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
        time.sleep(0.002)
    return time.perf_counter() - t


class Relabel:
    params = ["thread", "process", "dask"]
    param_names = ["backend"]
    timeout = 900
    number = repeat = rounds = 1

    def setup_cache(self):
        from streamseg.daemon.algorithms import Algorithms
        from streamseg.daemon.dask_worker import DaskRelabelWorker
        from streamseg.daemon.worker import RelabelWorker
        from streamseg.scaleout import local_cluster

        X = _features()
        alg = Algorithms()
        alg.warmup()
        out = {}
        for backend in self.params:
            cluster = None
            if backend == "dask":
                cluster = local_cluster(2)
                w = DaskRelabelWorker(alg, cluster.scheduler_address)
            else:
                w = RelabelWorker(alg, processes=2 if backend == "process" else 0, share=1.0)
            w.start()
            if backend == "dask":
                assert w.wait_connected(120), "the local cluster did not come up"
            w.warm()
            _drain(w, _jobs(X, 4))  # every worker warm
            times = [_drain(w, _jobs(X, JOBS)) for _ in range(3)]
            w.stop()
            if cluster is not None:
                cluster.close()
            out[backend] = JOBS / statistics.median(times)
        return out

    def track_jobs_per_s(self, rates, backend):
        return rates[backend]

    track_jobs_per_s.unit = "jobs/s"


def track_scheduler_ms_per_task():
    import distributed

    from streamseg.scaleout import local_cluster

    cluster = local_cluster(1)
    client = distributed.Client(cluster, set_as_default=False)
    client.submit(int, 0, pure=False).result()
    bulk = []
    for _ in range(3):
        t = time.perf_counter()
        client.gather(client.map(int, range(1000), pure=False))
        bulk.append((time.perf_counter() - t) / 1000)
    client.close()
    cluster.close()
    return statistics.median(bulk) * 1e3


track_scheduler_ms_per_task.unit = "ms"
track_scheduler_ms_per_task.timeout = 300
