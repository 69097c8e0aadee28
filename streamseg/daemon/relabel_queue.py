"""Which streams are relabelled next, and the job each gets.

Streams due for a relabel wait oldest first; each gets its snapshot only when the worker has
a free slot, so the interval a stream gets adapts to the cores (round robin) and a snapshot
is never older than the worker's queue.
"""

from __future__ import annotations

import collections

from streamseg.daemon.worker import RelabelJob


class RelabelQueue:
    """Streams due for a relabel, and their jobs handed to the worker.

    Parameters
    ----------
    worker : RelabelWorker or a scale-out backend
        ``free()``, ``pending(key)``, ``submit(job)``.
    interval : float
        Seconds of frames between a stream's cadence relabels (0: off).
    """

    def __init__(self, worker, interval: float):
        self.worker, self.interval = worker, interval
        self.due: collections.OrderedDict = collections.OrderedDict()  # stream state -> None

    def check(self, st) -> None:
        """Queue ``st`` if its pipeline says a relabel is due."""
        if self.interval > 0 and st.pipeline.relabel_due(st.next_relabel):
            self.due[st] = None

    def drop(self, st) -> None:
        self.due.pop(st, None)

    def feed(self, streams: dict) -> None:
        """Hand the oldest due streams' snapshots to the worker while it has free slots."""
        while self.due and self.worker.free() > 0:
            st, _ = self.due.popitem(last=False)
            if streams.get(st.stream) is st and not self.worker.pending((st.stream, st.gen)):
                self.submit(st, final=False)

    def submit(self, st, final: bool) -> bool:
        """One relabel job of ``st`` (``final``: the take's last); False when it has too few
        frames to relabel."""
        feats, frames, focused = st.pipeline.relabel_snapshot(
            final or st.pipeline.learned >= st.next_relabel
        )
        if feats.shape[0] < 2:
            return False
        if not focused:  # a relabel a cut made due leaves the cadence as it was
            st.next_relabel = st.pipeline.learned + int(round(self.interval * st.fps))
        self.worker.submit(
            RelabelJob(
                (st.stream, st.gen),
                feats,
                frames,
                st.fps,
                st.pipeline.previous,
                final,
                tuple(st.pipeline.cut_frames),
                focused,
            )
        )
        return True
