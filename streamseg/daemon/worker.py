"""The relabel worker: one job per stream at a time, run in a thread of the daemon or in a
pool of processes, as many at once as it has slots."""

from __future__ import annotations

import collections
import os
import threading
import time

from streamseg.daemon.relabel_job import relabel

#: Relabel processes run this much nicer than the daemon: a relabel takes the CPU ingest
#: leaves, so cuts stay on time whatever the number of streams and the cadence adapts.
PROCESS_NICE = 10


class RelabelJob:
    """A snapshot of one stream's features to relabel (taken by the ingest thread)."""

    __slots__ = (
        "key",
        "features",
        "frames",
        "fps",
        "previous",
        "final",
        "queued",
        "cuts",
        "focused",
    )

    def __init__(self, key, features, frames, fps, previous, final=False, cuts=(), focused=False):
        self.key = key  # (stream, generation): a re-announced stream is a new key
        self.features = features
        self.frames = frames
        self.fps = fps
        self.previous = previous
        self.final = final
        self.cuts = cuts  # live cut frames the relabel's boundaries may snap to
        self.focused = focused  # the window a provisional cut made due (not the history)
        self.queued = time.monotonic()


def _lower_priority() -> None:
    """Process pool initializer: below the daemon's loop thread in the scheduler's eyes."""
    try:
        os.nice(PROCESS_NICE)
    except OSError:  # not permitted here: run at the daemon's priority
        pass


class RelabelWorker(threading.Thread):
    """Runs relabel jobs off the ingest thread; results are collected with :meth:`results`.

    The ingest thread never waits on it: :meth:`submit` only takes a lock held for a few
    dictionary operations. The daemon asks :meth:`free` how many jobs it would start now and
    takes a stream's snapshot only then (it keeps the due streams, oldest first), so a job
    is never stale and no snapshot waits in memory; a stream with a job still queued has
    that job's snapshot replaced by a newer one.

    With ``processes = N > 0`` up to N jobs run at once in a pool of spawned processes, at
    :data:`PROCESS_NICE` (ACA's Python parts then run outside the daemon's GIL); with 0, one
    job at a time in this thread.
    """

    def __init__(self, algorithms, processes: int = 0, share: float = 1.0):
        super().__init__(name="streamseg-relabel", daemon=True)
        # In-thread relabels share the GIL with ingest; when jobs keep coming, pause after each
        # so relabelling takes at most this share of the time and ingest keeps the rest. A
        # job's cost is this thread's CPU time, not its wall time: waiting for the GIL while
        # other threads (ingest, the event log and checkpoint writers) hold it is not time
        # relabelling took from them, and counting it slowed relabels whenever they were busy.
        self.share = share
        self.algorithms = algorithms
        self.pool = None
        self.slots = max(int(processes), 1)
        if processes > 0:
            import concurrent.futures
            import multiprocessing

            self.pool = concurrent.futures.ProcessPoolExecutor(
                processes,
                mp_context=multiprocessing.get_context("spawn"),
                initializer=_lower_priority,
            )
        self._cond = threading.Condition()
        self._queue = collections.OrderedDict()
        self._busy: set = set()
        self._done = collections.deque()
        self._stopping = False

    def submit(self, job: RelabelJob) -> None:
        with self._cond:
            self._queue[job.key] = job  # replaces a queued older snapshot of the same stream
            self._cond.notify()

    def pending(self, key) -> bool:
        """True while a job of ``key`` is queued or running."""
        with self._cond:
            return key in self._queue or key in self._busy

    def running(self, key) -> bool:
        """True while a job of ``key`` runs."""
        with self._cond:
            return key in self._busy

    def free(self) -> int:
        """Jobs this worker would start now (slots neither running nor claimed by the queue)."""
        with self._cond:
            return max(self.slots - len(self._busy) - len(self._queue), 0)

    @property
    def busy_key(self):
        """A key whose job runs (None when none does): the daemon polls faster while busy."""
        with self._cond:
            return next(iter(self._busy), None)

    def queued(self) -> int:
        with self._cond:
            return len(self._queue)

    def results(self) -> list:
        """Finished ``(job, Relabelled or Exception)`` pairs, oldest first."""
        out = []
        while self._done:
            out.append(self._done.popleft())
        return out

    def notices(self) -> list:
        """Backend problems to report as errors (none here; see the dask backend)."""
        return []

    def warm(self) -> None:
        """Load the kernels in the worker processes too (before the first packet)."""
        if self.pool is not None:
            for fut in [self.pool.submit(self.algorithms.warmup) for _ in range(self.slots)]:
                fut.result()

    def stop(self, timeout: float | None = None) -> None:
        with self._cond:
            self._stopping = True
            self._queue.clear()
            self._cond.notify_all()
        if self.is_alive():
            self.join(timeout)
        if self.pool is not None:
            self.pool.shutdown(wait=False, cancel_futures=True)

    def _finished(self, job, result) -> None:
        self._done.append((job, result))
        with self._cond:
            self._busy.discard(job.key)
            self._cond.notify_all()

    def _returned(self, job, fut) -> None:
        """A process job's callback (the pool's thread)."""
        try:
            result = fut.result()
        except Exception as err:  # reported as an error event; the worker lives on
            result = err
        self._finished(job, result)

    def run(self) -> None:
        while True:
            with self._cond:
                while not self._stopping and not (self._queue and len(self._busy) < self.slots):
                    self._cond.wait()
                if self._stopping:
                    return
                key, job = self._queue.popitem(last=False)
                self._busy.add(key)
            if self.pool is not None:
                try:
                    fut = self.pool.submit(
                        relabel,
                        self.algorithms,
                        job.features,
                        job.frames,
                        job.fps,
                        job.previous,
                        job.cuts,
                    )
                except RuntimeError as err:  # the pool was shut down under us
                    self._finished(job, err)
                    continue
                fut.add_done_callback(lambda f, job=job: self._returned(job, f))
                continue
            started = time.thread_time()
            try:
                result = relabel(
                    self.algorithms, job.features, job.frames, job.fps, job.previous, job.cuts
                )
            except Exception as err:  # reported as an error event; the worker lives on
                result = err
            elapsed = time.thread_time() - started
            self._finished(job, result)
            if self.share < 1.0:  # the daemon hands the next job in meanwhile (free() is 1)
                with self._cond:
                    self._cond.wait_for(lambda: self._stopping, elapsed * (1.0 / self.share - 1.0))
