"""Checkpoints, the daemon's side: every open stream's state copied every
``checkpoint_interval`` seconds and restored at start, so a daemon killed with -9 and
restarted on the same state directory resumes its streams where the last checkpoint left
them.

A checkpoint holds the stream's bookkeeping (announce, next expected frame, counters, the last
``segments`` and recent cuts) and its pipeline: the cut detector's arrays, the feature ring
the relabels read, the last relabel result (stream-wide ids). The loop thread copies the
state of the streams that received frames since their last checkpoint
(:func:`streamseg.daemon.state_codec.dump`, 0.09 ms for a full stream), in steps of at most
:data:`STEP_BUDGET` of loop time; :class:`~streamseg.daemon.checkpoint_store.CheckpointStore`
writes them from its thread, storing only the 4 kB chunks of the arrays that changed since
the stream's previous checkpoint (a full 60 s x 120 Hz stream: 706 kB the first time, about
62 kB per 2 s after that, mostly the rings' newest rows). The detector's neighbour lists,
lrd and LOF are not stored: a restore rebuilds them from its window vectors (the same values
bit for bit; 2.4 ms for a full stream).
"""

from __future__ import annotations

import logging
import time

from streamseg.daemon.state_codec import dump
from streamseg.daemon.streams import StreamState

log = logging.getLogger("streamseg.daemon")


def snapshot(st: StreamState) -> dict:
    """A copy of one stream's state (the loop thread; no I/O)."""
    return dump({"stream": st, "pipeline": st.pipeline})


STEP_BUDGET = 0.002  # seconds of loop time per step of a checkpoint round
DUTY = 0.02  # at most this share of the loop's time goes to copying states
# Checkpoints take at most this share of one core on average (the loop's copies and the
# writer's CPU): after a round, the next one waits until the round's own cost / CPU_BUDGET
# has passed since it began. Measured (git show 0d6c5cf:benchmarks/daemon_throughput.py
# --event-log, 30 s runs): at a 2 s interval 250 full-rate streams spent 3.6 % of a core on
# checkpoints and relabelled up to 12 % less often
CPU_BUDGET = 0.015


class CheckpointRounds:
    """When checkpoint rounds run and which streams each copies (the loop thread).

    A round starts ``interval`` s after the last one began, or later, once the last round is
    written, when it cost more than ``CPU_BUDGET`` of a core over that time; it copies the
    streams that took frames since their last checkpoint. Each step copies streams for at
    most ``STEP_BUDGET`` s and the next step waits until the copying is at most ``DUTY`` of
    the loop's time, so the copying never delays packets by more than a step. The spacing is
    set by the round's own cost, not its predecessor's, so it holds while the streams (and
    so the rounds) grow. With a few streams the interval is ``interval``; with many it grows
    with their number (``stats`` reports the spacing as :attr:`gap`).

    Parameters
    ----------
    store : streamseg.daemon.checkpoint_store.CheckpointStore
        Where copies go (its writer thread stores them).
    interval : float
        ``checkpoint_interval``, seconds.
    copy : callable
        ``copy(state) -> (stream, frame, snapshot) or None``: one stream's copy (the daemon
        flushes the stream first and reports a state it cannot copy).
    """

    def __init__(self, store, interval: float, copy):
        self.store, self.interval, self.copy = store, interval, copy
        self.seconds = 0.0  # loop time spent copying stream states
        self.copied = 0  # stream states queued for the store
        self.seen: dict = {}  # stream -> frames_in at its last checkpoint
        self.gap = interval  # s between round starts, now
        self._next = 0.0  # monotonic time before which no round starts
        self._start = 0.0  # monotonic time the last round began
        self._round: list = []  # streams still to copy in this round
        self._resume = 0.0  # monotonic time of the round's next step
        self._spent = 0.0  # seconds + writer CPU when the last round began
        self._log_failed = 0  # the event log's failed writes when the last round began

    def begin(self, now: float) -> None:
        """The loop starts: the first round is ``interval`` s away."""
        self._start, self._next = now, now + self.interval

    @property
    def in_round(self) -> bool:
        return bool(self._round)

    def due(self, now: float) -> bool:
        return bool(self._round) or now >= self._next

    def forget(self, stream: str) -> None:
        self.seen.pop(stream, None)

    def _queue(self, states) -> int:
        items = []
        for st in states:
            item = self.copy(st)
            if item is not None:
                items.append(item)
                self.seen[st.stream] = st.frames_in
        if items:
            self.store.put(items)
        self.copied += len(items)
        return len(items)

    def all_now(self, streams: dict) -> int:
        """Queue a copy of every open stream at once (the control op ``checkpoint``)."""
        t0 = time.perf_counter()
        self._round = []
        n = self._queue(list(streams.values()))
        self.seconds += time.perf_counter() - t0
        return n

    def step(self, now: float, streams: dict, log_failed: int) -> int:
        """One step of the periodic rounds; ``log_failed``: the event log's failed writes so
        far (a round is skipped after new ones: the log goes first). Returns the streams
        copied."""
        store = self.store
        if not self._round:
            if now < self._next or store.busy():
                return 0
            if log_failed != self._log_failed:
                self._log_failed = log_failed
                store.paused += 1
                self._next = now + self.interval
                return 0
            spent = self.seconds + store.cpu_seconds
            cost = spent - self._spent  # the last round's, now that it is written
            self.gap = max(self.interval, cost / CPU_BUDGET)
            self._next = self._start + self.gap
            if now < self._next:
                return 0
            self._start, self._spent = now, spent
            self._next = now + self.interval
            self._round = [s for s, st in streams.items() if st.frames_in != self.seen.get(s)]
        elif now < self._resume:
            return 0
        t0 = time.perf_counter()
        batch = []
        while self._round and time.perf_counter() - t0 < STEP_BUDGET:
            st = streams.get(self._round.pop())
            if st is not None:
                batch.append(st)
        n = self._queue(batch)
        dt = time.perf_counter() - t0
        self._resume = now + dt / DUTY
        self.seconds += dt
        return n


def restored(store, algorithms):
    """The checkpointed streams' states, ready to run again (their pipelines given
    ``algorithms``); a checkpoint that cannot be restored is logged and skipped."""
    for stream, state in store.read_all():
        try:
            st = state["stream"]
            pipe = state["pipeline"]
            pipe.algorithms = algorithms
            pipe.plan = algorithms.prepare(pipe.skeleton)
            st.pipeline = pipe
        except Exception as err:
            log.error(
                "checkpoint of %s could not be restored (%s: %s)", stream, type(err).__name__, err
            )
            continue
        yield st
