"""Shutdown (SIGINT, SIGTERM, the control op): every stream's final events, then the
daemon's parts released, in order.

:class:`Shutdown` knows the daemon only through :class:`Finishing` (its streams side) and the
list of release steps the daemon gives it.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Protocol

from streamseg.daemon.relabel_job import relabel
from streamseg.daemon.worker import RelabelJob

log = logging.getLogger("streamseg.daemon")


class Finishing(Protocol):
    """What the final events need of the daemon (the loop thread)."""

    closing: dict  # (stream, gen) -> streams.Closing: takes awaiting their final relabel

    def take_queued(self) -> None:
        """Process every packet the ingest already received (it reads no more)."""

    def close_all(self, reason: str) -> None:
        """Close every open stream: final cuts, final relabel submitted (or ``closed``)."""

    def collect(self) -> None:
        """Publish the relabel results the worker has finished."""

    def feed(self) -> None:
        """Hand the worker the waiting relabel jobs it has room for."""

    def unqueue(self, key):
        """Take back the final job of ``key`` if it still waits for the worker (else None)."""

    def relabelled(self, job: RelabelJob, result) -> None:
        """Publish one relabel result (or failure) and what it settles."""

    def closed(self, st, reason: str) -> None:
        """Publish ``closed`` of a take (after what is left of its cuts)."""

    def beat(self) -> None:
        """Publish a last heartbeat."""


class Shutdown:
    """The daemon's way out.

    Parameters
    ----------
    daemon : Finishing
        The streams side.
    worker : streamseg.daemon.worker.RelabelWorker
        Runs the final relabels; whatever it has not started by the deadline is run here.
    algorithms : streamseg.daemon.algorithms.Algorithms
        For the relabels run here.
    budget : float
        ``shutdown_relabel``: seconds the final relabels may take together.
    heartbeat : bool
        Whether a last ``stats`` goes out after the ``closed`` events.
    """

    def __init__(self, daemon: Finishing, worker, algorithms, budget: float, heartbeat: bool):
        self.daemon, self.worker, self.algorithms = daemon, worker, algorithms
        self.budget, self.heartbeat = budget, heartbeat

    def final_events(self) -> None:
        """Close every stream: final cuts, a last relabel (bounded by ``budget``), then
        ``closed``; packets already received are processed first."""
        d = self.daemon
        d.take_queued()
        deadline = time.monotonic() + self.budget
        d.close_all("shutdown")
        # let the worker finish what it has (bounded), then do the rest here if time allows
        while d.closing and time.monotonic() < deadline:
            d.feed()
            d.collect()
            if not self.worker.is_alive():
                break
            time.sleep(0.005)
        d.collect()
        for key, (st, reason, job) in list(d.closing.items()):
            d.unqueue(key)  # the worker would not start it now
            if time.monotonic() < deadline and not self.worker.running(key):
                try:
                    res = relabel(
                        self.algorithms, job.features, job.frames, st.fps, job.previous, job.cuts
                    )
                except Exception as err:
                    res = err
                d.relabelled(RelabelJob(key, None, None, st.fps, None, final=True), res)
            else:
                d.closing.pop(key, None)
                d.closed(st, reason)
        if self.heartbeat:
            d.beat()

    @staticmethod
    def release(steps: list[tuple[str, Callable[[], object]]]) -> None:
        """Run each ``(what, step)`` in order; one that fails is logged and the rest still
        run (the state directory's lock, last, must always be given back)."""
        for what, step in steps:
            try:
                step()
            except Exception as err:  # never leave the rest unreleased
                log.error("shutdown: %s failed (%s: %s)", what, type(err).__name__, err)
        log.info("daemon stopped")
