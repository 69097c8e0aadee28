"""The relabel worker thread: one job per stream at a time, newest snapshot wins."""

from __future__ import annotations

import collections
import threading
import time

from streamseg.daemon.pipeline import relabel


class RelabelJob:
    """A snapshot of one stream's features to relabel (taken by the ingest thread)."""

    __slots__ = ("key", "features", "frames", "fps", "previous", "final", "queued", "cuts")

    def __init__(self, key, features, frames, fps, previous, final=False, cuts=()):
        self.key = key  # (stream, generation): a re-announced stream is a new key
        self.features = features
        self.frames = frames
        self.fps = fps
        self.previous = previous
        self.final = final
        self.cuts = cuts  # live cut frames the relabel's boundaries may snap to
        self.queued = time.monotonic()


class RelabelWorker(threading.Thread):
    """Runs relabel jobs off the ingest thread; results are collected with :meth:`results`.

    The ingest thread never waits on it: :meth:`submit` only takes a lock held for a few
    dictionary operations, and a stream with a job still queued has that job's snapshot
    replaced by the newer one (so a slow worker skips stale work instead of piling it up).
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
        if processes > 0:
            # ACA's Python parts then run outside this process's GIL; this thread only waits
            import concurrent.futures
            import multiprocessing

            self.pool = concurrent.futures.ProcessPoolExecutor(
                processes, mp_context=multiprocessing.get_context("spawn"))
        self._cond = threading.Condition()
        self._queue = collections.OrderedDict()
        self._done = collections.deque()
        self._stopping = False
        self.busy_key = None

    def submit(self, job: RelabelJob) -> None:
        with self._cond:
            self._queue[job.key] = job  # replaces a queued older snapshot of the same stream
            self._cond.notify()

    def pending(self, key) -> bool:
        """True while a job of ``key`` is queued or running."""
        with self._cond:
            return key in self._queue or self.busy_key == key

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
            self.pool.submit(self.algorithms.warmup).result()

    def stop(self, timeout: float | None = None) -> None:
        with self._cond:
            self._stopping = True
            self._queue.clear()
            self._cond.notify()
        if self.is_alive():
            self.join(timeout)
        if self.pool is not None:
            self.pool.shutdown(wait=False, cancel_futures=True)

    def run(self) -> None:
        while True:
            with self._cond:
                while not self._queue and not self._stopping:
                    self._cond.wait()
                if self._stopping:
                    return
                key, job = self._queue.popitem(last=False)
                self.busy_key = key
            started = time.thread_time()
            try:
                if self.pool is not None:
                    result = self.pool.submit(relabel, self.algorithms, job.features, job.frames,
                                              job.fps, job.previous, job.cuts).result()
                else:
                    result = relabel(self.algorithms, job.features, job.frames, job.fps,
                                     job.previous, job.cuts)
            except Exception as err:  # reported as an error event; the worker lives on
                result = err
            elapsed = time.thread_time() - started
            self._done.append((job, result))
            with self._cond:
                self.busy_key = None
                if self.pool is None and self.share < 1.0 and self._queue:
                    self._cond.wait_for(lambda: self._stopping,
                                        elapsed * (1.0 / self.share - 1.0))
