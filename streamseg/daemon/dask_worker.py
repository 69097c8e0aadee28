"""The ``dask`` relabel backend: relabel jobs on a Dask cluster, the local worker as fallback.

:class:`DaskRelabelWorker` has the interface of :class:`~streamseg.daemon.worker.
RelabelWorker` (``submit``, ``pending``, ``queued``, ``results``, ``busy_key``, ``stop``), so
the daemon's loop is the same for every backend. Its own thread takes jobs from the same
newest-snapshot-wins queue and submits each (the features window, the stream frame numbers,
the previous revision's window, the live cuts: :func:`streamseg.daemon.relabel_job.relabel`'s
arguments) to a :class:`distributed.Client`; results come back through future callbacks and
the daemon publishes them as they arrive. A stream has at most one job out at a time, so its
revisions return in order, and a job queued behind a running one gets that one's window as
its ``previous`` when it returns.

The daemon's ingest thread never touches the client: :meth:`submit` is the same few dict
operations under a lock as the thread backend's. Connecting, reconnecting and asking the
scheduler how many threads it has happen in a connector thread. When the cluster fails a
job (its worker died more often than the scheduler retries, the scheduler went away, the job
took longer than ``timeout``), or while no cluster with workers is reachable, jobs run on a
local thread backend instead; each such event is a ``notice`` that the daemon publishes as an
``error`` event (reason ``relabel_backend``). Nothing waits on the cluster.
"""

from __future__ import annotations

import collections
import logging
import threading
import time

from streamseg.daemon.relabel_job import relabel
from streamseg.daemon.worker import RelabelWorker
from streamseg.scaleout import require_distributed

log = logging.getLogger("streamseg.daemon")


def remote_relabel(algorithms, features, frames, fps, previous, cuts):
    """The task a Dask worker runs: ``("ok", Relabelled)`` or ``("error", exception)``.

    An exception of the algorithm is returned, not raised, so that the daemon tells it (an
    ``error`` event ``relabel``, as with the thread backend) from a failure of the cluster
    (fallback to the local backend).
    """
    try:
        return "ok", relabel(algorithms, features, frames, fps, previous, cuts)
    except Exception as err:
        return "error", err


class DaskRelabelWorker(threading.Thread):
    """Relabel jobs on the Dask scheduler at ``address`` (``""``: a local cluster, one worker
    process per core on 127.0.0.1, started here).

    Parameters
    ----------
    algorithms : Algorithms
        Sent with every job (small: configurations).
    address : str
        Scheduler address, e.g. ``tcp://10.0.0.5:8786``; ``""`` starts a LocalCluster.
    share : float
        The local fallback's ``share`` (see :class:`RelabelWorker`).
    timeout : float
        Seconds a job may be out on the cluster before it is run locally instead.
    per_thread : int
        Jobs kept out per worker thread of the cluster (the rest wait here, where a newer
        snapshot of the same stream replaces an older one).
    connect_timeout : float
        Seconds one connection attempt may take (the client's reconnect window, too).
    """

    def __init__(
        self,
        algorithms,
        address: str = "",
        share: float = 1.0,
        timeout: float = 120.0,
        per_thread: int = 2,
        connect_timeout: float = 5.0,
    ):
        super().__init__(name="streamseg-relabel-dask", daemon=True)
        self.distributed = require_distributed()
        self.algorithms = algorithms
        self.address = address
        self.timeout = timeout
        self.per_thread = per_thread
        self.connect_timeout = connect_timeout
        self.local = RelabelWorker(algorithms, share=share)
        self.client = None
        self.cluster = None
        self.threads = 0  # worker threads the cluster has (refreshed by the connector)
        self._cond = threading.Condition()
        self._queue = collections.OrderedDict()
        self._out: dict = {}  # key -> (job, future, sent at)
        self._done = collections.deque()
        self._notices = collections.deque()
        self._stopping = False
        self._connected = threading.Event()
        self._counter = 0
        self._warmed: dict = {}  # worker address -> its warm-up future
        self.sent = self.returned = self.fallbacks = 0
        self._connector = threading.Thread(
            target=self._connect_loop, daemon=True, name="streamseg-relabel-dask-connect"
        )

    # --- the interface the daemon uses -------------------------------------------------------

    def submit(self, job) -> None:
        with self._cond:
            self._queue[job.key] = job
            self._cond.notify_all()

    def pending(self, key) -> bool:
        with self._cond:
            return key in self._queue or key in self._out or self.local.pending(key)

    def queued(self) -> int:
        with self._cond:
            return len(self._queue) + self.local.queued()

    def free(self) -> int:
        """Jobs it would start now: room on the cluster (or in the local fallback while no
        cluster is usable) not taken by jobs out or queued."""
        with self._cond:
            if not self._usable():
                return max(self.local.free() - len(self._queue), 0)
            return max(self._capacity() - len(self._out) - len(self._queue), 0)

    def running(self, key) -> bool:
        """True while a job of ``key`` is out on the cluster or runs locally."""
        with self._cond:
            return key in self._out or self.local.running(key)

    @property
    def busy_key(self):
        """A key with a job out (None when none is): the daemon polls faster while busy."""
        with self._cond:
            if self._out:
                return next(iter(self._out))
        return self.local.busy_key

    def results(self) -> list:
        """Finished ``(job, Relabelled or Exception)`` pairs, from the cluster and the local
        fallback."""
        out = []
        while self._done:
            out.append(self._done.popleft())
        local = self.local.results()
        if local:
            out += local
            with self._cond:
                self._cond.notify_all()  # a stream the fallback had may now go out again
        return out

    def notices(self) -> list:
        """``(stream or None, reason, message)`` for the daemon to publish as errors."""
        out = []
        while self._notices:
            out.append(self._notices.popleft())
        return out

    def warm(self) -> None:
        """Nothing to wait for: the connector warms each worker when it connects."""

    def start(self) -> None:
        self.local.start()
        self._connector.start()
        super().start()

    def wait_connected(self, timeout: float | None = None) -> bool:
        """True once a cluster is connected (tests and benchmarks wait on this)."""
        return self._connected.wait(timeout)

    def wait_warm(self, timeout: float | None = None) -> bool:
        """True once a cluster is connected and each of its workers has its kernels loaded
        (tests and benchmarks wait on this before they time or gate jobs: a worker still
        warming takes no job, so a job would wait for it)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        if not self._connected.wait(timeout):
            return False
        for future in list(self._warmed.values()):
            left = None if deadline is None else max(deadline - time.monotonic(), 0.0)
            try:
                future.exception(timeout=left)  # waits; a failed warm-up is warm enough
            except TimeoutError:
                return False
            except Exception as err:  # cancelled: its worker left; the others still count
                log.debug("warm-up future: %s", err)
        return True

    def stop(self, timeout: float | None = None) -> None:
        with self._cond:
            self._stopping = True
            self._queue.clear()
            out = list(self._out.values())
            self._out.clear()
            self._cond.notify_all()
        for _, fut, _ in out:
            if fut is not None:
                fut.cancel()
        if self.is_alive():
            self.join(timeout)
        self.local.stop(timeout)
        client, cluster = self.client, self.cluster
        self.client = None
        for thing in (client, cluster):
            if thing is not None:
                try:
                    thing.close(timeout=5) if thing is client else thing.close()
                except Exception as err:  # closing a client of a dead scheduler may fail
                    log.debug("closing %s: %s", type(thing).__name__, err)

    # --- connecting ---------------------------------------------------------------------------

    def _notice(self, stream, message: str) -> None:
        self._notices.append((stream, "relabel_backend", message))

    def _connect_loop(self) -> None:
        """Keep a connected client while running; refresh the cluster's thread count."""
        lost_said = False
        while not self._stopping:
            client = self.client
            if client is None or client.status in ("closed", "closing", "failed"):
                self._connected.clear()
                self.threads = 0
                try:
                    client = self._open()
                except Exception as err:
                    if not lost_said:
                        self._notice(
                            None,
                            f"the Dask scheduler {self.address or '(local)'} is "
                            f"not reachable ({type(err).__name__}: {err}); relabelling "
                            "locally until it is",
                        )
                        lost_said = True
                    self._wait(1.0)
                    continue
                self.client = client
                lost_said = False
                log.info("relabel backend: Dask scheduler %s", client.scheduler.address)
            try:
                workers = client.nthreads() if client.status == "running" else {}
            except Exception:  # the scheduler went away between the check and the call
                workers = {}
            self._warm(client, workers)
            self.threads = sum(workers.values())
            if self.threads:
                self._connected.set()
            else:
                self._connected.clear()
            with self._cond:
                self._cond.notify_all()
            self._wait(0.5)

    def _open(self):
        distributed = self.distributed
        if self.address:
            client = distributed.Client(
                self.address, timeout=self.connect_timeout, set_as_default=False
            )
        else:
            if self.cluster is None:
                from streamseg.scaleout import local_cluster

                self.cluster = local_cluster()
            client = distributed.Client(self.cluster, set_as_default=False)
        return client

    def _warm(self, client, workers: dict) -> None:
        """Load the kernels once on each new worker (a task pinned to it; not waited for)."""
        for addr in workers:
            if addr not in self._warmed:
                self._warmed[addr] = client.submit(
                    self.algorithms.warmup,
                    workers=[addr],
                    allow_other_workers=False,
                    pure=False,
                    key=f"relabel-warmup-{addr}",
                )
        for addr in [a for a, f in self._warmed.items() if a not in workers and f.done()]:
            del self._warmed[addr]

    def _wait(self, seconds: float) -> None:
        with self._cond:
            self._cond.wait_for(lambda: self._stopping, seconds)

    # --- dispatching -----------------------------------------------------------------------

    def _capacity(self) -> int:
        return max(self.threads * self.per_thread, 1)

    def _next(self):
        """A queued job whose stream has nothing out, or None (caller holds the lock)."""
        for key, job in self._queue.items():
            if key not in self._out and not self.local.pending(key):
                del self._queue[key]
                return job
        return None

    def run(self) -> None:
        while True:
            with self._cond:
                job = None
                while not self._stopping:
                    self._expire()
                    up = self._usable()
                    if not up or len(self._out) < self._capacity():
                        job = self._next()
                        if job is not None:
                            break
                    self._cond.wait(0.25)
                if self._stopping:
                    return
                if not up:
                    self._fallback(job, None)
                    continue
                self._counter += 1
                key = f"relabel-{job.key[0]}-{job.key[1]}-{self._counter}"
                client, sent = self.client, time.monotonic()
                self._out[job.key] = (job, None, sent)  # out, being sent
            # outside the lock: pickling a 1 MB window must not hold up the ingest thread
            try:
                fut = client.submit(
                    remote_relabel,
                    self.algorithms,
                    job.features,
                    job.frames,
                    job.fps,
                    job.previous,
                    job.cuts,
                    key=key,
                    pure=False,
                )
            except Exception as err:  # the client closed under us
                with self._cond:
                    self._out.pop(job.key, None)
                    self._fallback(job, f"could not submit ({type(err).__name__}: {err})")
                continue
            with self._cond:
                if self._out.get(job.key) != (job, None, sent):  # stopped or expired meanwhile
                    fut.cancel()
                    continue
                self._out[job.key] = (job, fut, sent)
                self.sent += 1
            fut.add_done_callback(lambda f, job=job: self._returned(job, f))

    def _usable(self) -> bool:
        c = self.client
        return c is not None and self.threads > 0 and c.status == "running"

    def _expire(self) -> None:
        """Jobs out longer than ``timeout`` (e.g. a cluster without workers) run locally."""
        now = time.monotonic()
        for key, (job, fut, sent) in list(self._out.items()):
            if now - sent > self.timeout:
                del self._out[key]
                if fut is not None:
                    fut.cancel()
                self._fallback(job, f"no result from the cluster in {self.timeout:g} s")

    def _fallback(self, job, why) -> None:
        """Run ``job`` on the local backend (caller holds the lock)."""
        self.fallbacks += 1
        if why is not None:
            self._notice(
                job.key[0], f"relabel job sent to the Dask cluster failed: {why}; it runs locally"
            )
        self.local.submit(job)

    def _returned(self, job, fut) -> None:
        """A future's callback (the client's callback thread): queue its result or fall back.

        The result is fetched from the worker outside the lock, so that the daemon's ingest
        thread (which takes the lock in :meth:`submit`) never waits on the network.
        """
        with self._cond:
            entry = self._out.get(job.key)
            if entry is None or entry[1] is not fut or self._stopping:
                return  # expired or stopped meanwhile: already handled
        value, why = None, None
        if fut.status == "finished":
            try:
                value = fut.result(timeout=self.timeout)  # fetched from the worker
            except Exception as err:  # finished but lost before it was fetched
                why = f"{type(err).__name__}: {err}"
        else:
            try:
                err = fut.exception(timeout=self.connect_timeout)
                why = f"{type(err).__name__}: {err}"
            except Exception as exc:  # cancelled: the scheduler connection was lost
                why = f"{fut.status} ({type(exc).__name__}: {exc})"
        with self._cond:
            entry = self._out.get(job.key)
            if entry is None or entry[1] is not fut:
                return
            del self._out[job.key]
            if why is not None:
                self._fallback(job, why)
            else:
                kind, result = value
                self.returned += 1
                self._done.append((job, result))
                later = self._queue.get(job.key)
                if kind == "ok" and later is not None:
                    later.previous = result.window  # the revision it follows
            self._cond.notify_all()
