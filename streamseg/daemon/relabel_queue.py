"""Which streams are relabelled next, and the job each gets.

Streams due for a relabel wait oldest first; each gets its snapshot only when the worker has
a free slot, so the interval a stream gets adapts to the cores (round robin) and a snapshot
is never older than the worker's queue. Takes that ended wait here too, each with the
snapshot of its final relabel (its detector state is freed), bounded in bytes; the worker's
free slots go to them and to the live streams in turn, so a backlog of ended takes never
stops the live streams' revisions.
"""

from __future__ import annotations

import collections

from streamseg.daemon.worker import RelabelJob


def job_bytes(job: RelabelJob) -> int:
    """Bytes a waiting job holds (its features and their frame numbers)."""
    return job.features.nbytes + job.frames.nbytes


class RelabelQueue:
    """Streams due for a relabel and ended takes' final relabels, handed to the worker.

    Parameters
    ----------
    worker : RelabelWorker or a scale-out backend
        ``free()``, ``pending(key)``, ``submit(job)``.
    interval : float
        Seconds of frames between a stream's cadence relabels (0: off).
    final_bytes : int
        Bytes the waiting final relabels may hold together (``final_relabel_bytes``).
    """

    def __init__(self, worker, interval: float, final_bytes: int = 64 << 20):
        self.worker, self.interval = worker, interval
        self.due: collections.OrderedDict = collections.OrderedDict()  # stream state -> None
        self.finals: collections.OrderedDict = collections.OrderedDict()  # key -> job
        self.final_limit = final_bytes
        self.final_bytes = 0  # held by the waiting final jobs
        self._final_turn = True  # the next free slot goes to a final job (when both wait)

    def check(self, st) -> None:
        """Queue ``st`` if its pipeline says a relabel is due."""
        if self.interval > 0 and st.pipeline.relabel_due(st.next_relabel):
            self.due[st] = None

    def drop(self, st) -> None:
        self.due.pop(st, None)

    def feed(self, streams: dict) -> None:
        """While the worker has free slots, hand it the oldest final job and the oldest due
        stream's snapshot, in turn."""
        while self.worker.free() > 0 and (self.due or self.finals):
            if self.finals and (self._final_turn or not self.due):
                key, job = self.finals.popitem(last=False)
                self.final_bytes -= job_bytes(job)
                self.worker.submit(job)
                self._final_turn = False
                continue
            st, _ = self.due.popitem(last=False)
            if streams.get(st.stream) is st and not self.worker.pending((st.stream, st.gen)):
                self.submit(st, final=False)
                self._final_turn = True

    def final_job(self, st) -> RelabelJob | None:
        """The final relabel job of an ended take (its whole history); None when it has too
        few frames to relabel."""
        return self._job(st, final=True)

    def room_for(self, job: RelabelJob) -> bool:
        """Whether ``job`` may wait for the worker within the byte bound (one always may
        when none waits)."""
        return not self.finals or self.final_bytes + job_bytes(job) <= self.final_limit

    def wait_final(self, job: RelabelJob) -> None:
        """``job`` waits for a free slot of the worker (after the final jobs before it)."""
        self.finals[job.key] = job
        self.final_bytes += job_bytes(job)

    def hurry(self, key) -> None:
        """The final job of ``key`` goes first: a newer take of its stream id waits for it
        (its events are published after the older take's ``closed``)."""
        if key in self.finals:
            self.finals.move_to_end(key, last=False)

    def waiting(self, key) -> bool:
        """True while the final job of ``key`` waits here (not yet the worker's)."""
        return key in self.finals

    def take_waiting(self, key) -> RelabelJob | None:
        """Remove the waiting final job of ``key`` (the shutdown runs it itself)."""
        job = self.finals.pop(key, None)
        if job is not None:
            self.final_bytes -= job_bytes(job)
        return job

    def submit(self, st, final: bool) -> bool:
        """One relabel job of ``st`` to the worker now (``final``: the take's last); False
        when it has too few frames to relabel."""
        job = self._job(st, final)
        if job is None:
            return False
        self.worker.submit(job)
        return True

    def _job(self, st, final: bool) -> RelabelJob | None:
        feats, frames, focused = st.pipeline.relabel_snapshot(
            final or st.pipeline.learned >= st.next_relabel
        )
        if feats.shape[0] < 2:
            return None
        if not focused:  # a relabel a cut made due leaves the cadence as it was
            st.next_relabel = st.pipeline.learned + int(round(self.interval * st.fps))
        return RelabelJob(
            (st.stream, st.gen),
            feats,
            frames,
            st.fps,
            st.pipeline.previous,
            final,
            tuple(st.pipeline.cut_frames),
            focused,
        )
