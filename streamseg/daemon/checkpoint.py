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

from streamseg.daemon import limits
from streamseg.daemon.state_codec import dump
from streamseg.daemon.streams import StreamState
from streamseg.protocol import SEQ_SKIP

log = logging.getLogger("streamseg.daemon")


def snapshot(st: StreamState) -> dict:
    """A copy of one stream's state (the loop thread; no I/O)."""
    return dump({"stream": st, "pipeline": st.pipeline})


def checkpoint(daemon) -> int:
    """Queue a checkpoint of every open stream at once (the control op ``checkpoint``);
    returns how many."""
    store = daemon.checkpoints
    if store is None:
        return 0
    t0 = time.perf_counter()
    items = []
    daemon._ckpt_round = []
    for st in list(daemon.streams.values()):
        _copy(daemon, st, items)
    if items:
        store.put(items)
    daemon.totals["checkpoints"] += len(items)
    daemon.checkpoint_seconds += time.perf_counter() - t0
    return len(items)


STEP_BUDGET = 0.002  # seconds of loop time per step of a checkpoint round
DUTY = 0.02  # at most this share of the loop's time goes to copying states
# Checkpoints take at most this share of one core on average (the loop's copies and the
# writer's CPU): after a round, the next one waits until the round's own cost / CPU_BUDGET
# has passed since it began. Measured (git show 0d6c5cf:benchmarks/daemon_throughput.py
# --event-log, 30 s runs): at a 2 s interval 250 full-rate streams spent 3.6 % of a core on
# checkpoints and relabelled up to 12 % less often
CPU_BUDGET = 0.015


def step(daemon, now: float) -> int:
    """One step of the periodic checkpoint: a round starts ``checkpoint_interval`` s after
    the last one began, or later, once the last round is written, when it cost more than
    ``CPU_BUDGET`` of a core over that time; it copies the streams that took frames since
    their last checkpoint. Each step copies streams for at most ``STEP_BUDGET`` s and the
    next step waits until the copying is at most ``DUTY`` of the loop's time, so the copying
    never delays packets by more than a step. The spacing is set by the round's own cost,
    not its predecessor's, so it holds while the streams (and so the rounds) grow. With a
    few streams the interval is ``checkpoint_interval``; with many it grows with their
    number (``stats`` reports the spacing; ``docs/protocol.md`` the measured intervals).
    Returns the streams copied."""
    store = daemon.checkpoints
    if not daemon._ckpt_round:
        if now < daemon._next_ckpt or store.busy():
            return 0
        elog = daemon.eventlog
        if elog is not None and elog.failed != daemon._log_failed_seen:
            # the event log could not write since the last round (a full disk?): it goes
            # first, this round is skipped
            daemon._log_failed_seen = elog.failed
            store.paused += 1
            daemon._next_ckpt = now + daemon.config.checkpoint_interval
            return 0
        spent = daemon.checkpoint_seconds + store.cpu_seconds
        cost = spent - daemon._ckpt_spent  # the last round's, now that it is written
        daemon.checkpoint_gap = max(daemon.config.checkpoint_interval, cost / CPU_BUDGET)
        daemon._next_ckpt = daemon._ckpt_start + daemon.checkpoint_gap
        if now < daemon._next_ckpt:
            return 0
        daemon._ckpt_start, daemon._ckpt_spent = now, spent
        daemon._next_ckpt = now + daemon.config.checkpoint_interval
        seen = daemon._ckpt_seen
        daemon._ckpt_round = [s for s, st in daemon.streams.items()
                              if st.frames_in != seen.get(s)]
    elif now < daemon._ckpt_resume:
        return 0
    t0 = time.perf_counter()
    items = []
    while daemon._ckpt_round and time.perf_counter() - t0 < STEP_BUDGET:
        st = daemon.streams.get(daemon._ckpt_round.pop())
        if st is not None:
            _copy(daemon, st, items)
    if items:
        store.put(items)
    dt = time.perf_counter() - t0
    daemon._ckpt_resume = now + dt / DUTY
    daemon.totals["checkpoints"] += len(items)
    daemon.checkpoint_seconds += dt
    return len(items)


def _copy(daemon, st, items: list) -> None:
    q = daemon.order.get(st.stream) if daemon.order else None
    if q and q[0][0] != st.gen:
        # a take waiting for an older one's `closed`: not resumed after a crash either, so
        # nothing of it can come out before that `closed`
        return
    daemon._flush(st)
    daemon._dirty.pop(st, None)
    try:
        items.append((st.stream, st.next_seq, snapshot(st)))
    except Exception as err:  # e.g. a custom algorithm with state we cannot copy
        daemon._error(st.stream, "checkpoint", f"stream state not checkpointed: "
                      f"{type(err).__name__}: {err}")
        return
    daemon._ckpt_seen[st.stream] = st.frames_in


def restore(daemon, now: float) -> int:
    """Open the checkpointed streams again (before the loop runs); returns how many."""
    store = daemon.checkpoints
    if store is None:
        return 0
    n = 0
    for stream, state in store.read_all():
        try:
            st = state["stream"]
            pipe = state["pipeline"]
            pipe.algorithms = daemon.algorithms
            pipe.plan = daemon.algorithms.prepare(pipe.skeleton)
            if not hasattr(pipe, "root"):  # saved before the root speeds: a detector without
                pipe.root = None
            st.pipeline = pipe
            st.pending, st.arrivals = [], []
            st.gap_limit = limits.RateLimit(daemon.config.gap_events_per_s)
            st.last_seen = now
            daemon._gen += 1
            st.gen = daemon._gen
        except Exception as err:
            log.error("checkpoint of %s could not be restored (%s: %s)", stream,
                      type(err).__name__, err)
            continue
        daemon.streams[stream] = st
        daemon._ckpt_seen[stream] = st.frames_in
        # events published in the last moments before the crash may not have reached the log:
        # their numbers are skipped, never reused for other events
        # (published only once logged, they are there unless the disk refused them)
        last = daemon.numbering.current(stream)
        daemon.numbering.last[stream] = last + SEQ_SKIP
        if daemon.eventlog is not None:  # `since` says they were skipped, not lost
            daemon.eventlog.skip(stream, last + 1, last + SEQ_SKIP)
        if st.client is not None:
            daemon.clients[st.client] += 1
        n += 1
        log.info("stream %s restored from its checkpoint at frame %d", stream, st.next_seq)
    daemon.totals["streams_restored"] += n
    return n
