"""One relabel job in stream frames (:func:`relabel`, run by the worker, a Dask worker or the
shutdown's final relabels) and its result (:class:`Relabelled`)."""

from __future__ import annotations

import time
from dataclasses import dataclass

from streamseg.daemon.alternation import merge_alternations
from streamseg.offline.identity import snap_to_cuts, stable_labels

__all__ = ["Relabelled", "relabel", "segment_triplets"]


@dataclass(frozen=True)
class Relabelled:
    """A relabel mapped to stream frames: ``segments`` are ``(start, end, label)``."""

    start: int
    end: int
    segments: tuple
    window: object  # the same as a WindowSegmentation in stream frames (the next ``previous``)
    elapsed: float


def segment_triplets(window) -> list:
    """``(start, end, label)`` of the algorithm's segments (objects or tuples)."""
    out = []
    for s in window.segments:
        if hasattr(s, "start"):
            out.append((int(s.start), int(s.end), int(s.label)))
        else:
            out.append((int(s[0]), int(s[1]), int(s[2])))
    return out


def relabel(algorithms, features, frames, fps, previous, cuts=()) -> Relabelled:
    """Run one relabel job in stream frames (runs in the worker).

    The algorithm sees ``start_frame = frames[0]`` and contiguous rows; a segment bound ``b``
    is row ``b - frames[0]``, mapped back through ``frames`` (the identity without dropped
    frames). Boundaries between actions then move to a live cut (``cuts``, stream frames)
    within the shortest segment length, ``min_len`` (:func:`snap_to_cuts`), and ids are made
    stream-wide (:func:`stable_labels`: the overlap with ``previous``; never a reused id;
    with ``algorithms.memory_config``, also the exemplars of ids the window no longer holds,
    clustered with it: :mod:`streamseg.offline.label_memory`).
    """
    from dataclasses import replace

    from streamseg.offline.label_memory import new_memory
    from streamseg.offline.recall import recall
    from streamseg.offline.relabel import WindowSegmentation

    t = time.perf_counter()
    start = int(frames[0])
    mcfg = algorithms.memory_config
    window = algorithms.relabel(features, start, fps)
    m = frames.shape[0]
    segs = []
    for a, b, label in segment_triplets(window):
        a_i, b_i = a - start, b - start
        if b_i <= 0 or a_i >= m:
            continue
        a_i, b_i = max(a_i, 0), min(b_i, m)
        segs.append((int(frames[a_i]), int(frames[b_i - 1]) + 1, int(label)))
    radius = int(round(algorithms.relabel_config.min_len_s * fps))
    segs = snap_to_cuts(segs, [c for c in cuts if start < c < int(frames[-1])], radius)
    if algorithms.alternations:
        segs = merge_alternations(segs)
    k = int(getattr(window, "n_clusters", 0))
    stable = stable_labels(WindowSegmentation(start, int(frames[-1]) + 1, segs, k), previous)
    if mcfg is not None:
        memory = getattr(previous, "memory", None) or new_memory(mcfg, fps, start)
        stable, memory, _ = recall(stable, previous, memory, features, frames, mcfg, fps)
        memory = memory.updated(stable.segments, features, frames, mcfg, fps)
        stable = replace(stable, memory=memory)
    elapsed = time.perf_counter() - t
    return Relabelled(stable.start, stable.end, tuple(stable.segments), stable, elapsed)
