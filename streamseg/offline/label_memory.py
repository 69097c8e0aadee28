"""A bounded memory of a stream's actions, so an action that returns after the relabel history
gets its old id.

Each relabel clusters only the last H seconds (``DaemonConfig.relabel_history``); ids are
carried between revisions by the frames two windows share (:mod:`streamseg.offline.identity`).
An action last seen before the window would otherwise come back with a new id.

:class:`ExemplarMemory` keeps, for up to ``max_ids`` of the stream's ids, ``per_id``
*exemplars*: actual feature frames of the id (at most ``exemplar_s`` seconds each, every
``round(fps / rate_hz)``-th frame), cut from equal parts of its longest run (without a
quarter of ``exemplar_s`` at either end, near the neighbours) in the last revision where that
run began and ended inside the window (the first view, until there is a whole one). When
more ids are remembered, those the current revision does not hold go first, the ones with the
shortest run first (short-lived ids of unstable revisions), then the ones seen longest ago.

The exemplars never enter the window's fit: after the overlap has carried the ids, a cluster
the overlap does not explain is compared with the remembered ids the revision does not hold,
and takes one only on strong evidence relative to the data (:mod:`streamseg.offline.recall`).
While the window still begins at the stream's first frame nothing is recalled. The split
merge (``LabelMemoryConfig.merge_present``, on) works from the first revision: two clusters
of one revision that touch and pass the recall's test share an id, so a take within the
history keeps the boundaries it has without the memory, not always its ids (tested).

Memory per stream: at most ``LabelMemoryConfig.max_bytes(d)`` (130 kB for 17 features with
the defaults), plus two small dicts of ints (``born`` over the ids of the last revision and
the remembered ones, ``pending`` over the last revision's candidates).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from streamseg.state import Stateful


@dataclass
class ExemplarMemory(Stateful):
    """The exemplars of one stream (module docstring). Treated as immutable:
    :meth:`updated` returns a new memory, so a relabel job can run on a copy.

    Attributes
    ----------
    stride : int
        Exemplars keep every ``stride``-th frame.
    exemplars : dict
        Stream id -> tuple of ``(m, d)`` float32 arrays.
    weight : dict
        Stream id -> length in frames of the run its exemplars come from.
    last_seen : dict
        Stream id -> end frame (exclusive) of its last segment seen.
    origin : int
        The first frame of the stream's first relabel window: while windows still begin
        there, nothing has left the history and no id is recalled.
    born : dict
        Stream id -> the revision that first gave it (-1: recalled, an old id); kept for the
        ids of the last revision and the remembered ones (:mod:`streamseg.offline.recall`).
    pending : dict
        Candidate id -> remembered id the last revision proposed (``recall_confirm = 2``).
    revisions : int
        Revisions seen.
    """

    stride: int = 1
    exemplars: dict = field(default_factory=dict)
    weight: dict = field(default_factory=dict)
    last_seen: dict = field(default_factory=dict)
    origin: int = 0
    born: dict = field(default_factory=dict)
    pending: dict = field(default_factory=dict)
    revisions: int = 0

    @property
    def nbytes(self) -> int:
        """Bytes held by the exemplar frames."""
        return int(sum(a.nbytes for ex in self.exemplars.values() for a in ex))

    def updated(self, segments, features, frames, config, fps: float) -> ExemplarMemory:
        """The memory after one revision.

        Parameters
        ----------
        segments : list of (start, end, id)
            The revision in stream frames and stream ids.
        features : (m, d) array
            The window's feature rows; ``frames`` (m,) their stream frame numbers.
        config : LabelMemoryConfig
        fps : float
        """
        frames = np.asarray(frames)
        ex, weight, seen = dict(self.exemplars), dict(self.weight), dict(self.last_seen)
        runs: dict = {}
        for a, b, lab in _runs(segments):
            runs.setdefault(lab, []).append((a, b))
            seen[lab] = max(seen.get(lab, 0), b)
        keep = max(1, int(round(config.exemplar_s * fps)))
        margin = keep // 4  # frames at each end of a run, near its neighbours, left out
        lo, hi = int(frames[0]), int(frames[-1]) + 1
        for lab, rs in runs.items():
            a, b = max(rs, key=lambda r: r[1] - r[0])
            whole = lo < a and b < hi  # the run begins and ends inside the window
            if lab in ex and not whole:
                continue  # a view cut by the window's edge: keep the last whole one
            r0, r1 = np.searchsorted(frames, [a, b])
            r0, r1 = r0 + margin, r1 - margin
            if r1 - r0 < keep:
                continue  # too short to stand for the action
            parts = np.linspace(r0, r1, config.per_id + 1).astype(np.int64)
            new = []
            for p0, p1 in zip(parts[:-1], parts[1:], strict=True):
                mid, half = (p0 + p1) // 2, min(keep, p1 - p0) // 2
                rows = np.asarray(features[mid - half : mid + half : self.stride], dtype=np.float32)
                rows = rows[np.isfinite(rows).all(axis=1)]
                if rows.shape[0] >= 2:
                    new.append(rows)
            if new:
                ex[lab] = tuple(new)
                weight[lab] = int(b - a)
        if len(ex) > config.max_ids:
            # forget first the ids this revision does not hold that covered the fewest
            # frames (short-lived ids of unstable revisions), then the ones seen longest ago
            order = sorted(ex, key=lambda i: (i in runs, weight.get(i, 0), seen.get(i, 0), i))
            for lab in order[: len(ex) - config.max_ids]:
                ex.pop(lab)
                weight.pop(lab, None)
        seen = {i: seen[i] for i in ex}
        return replace(self, exemplars=ex, weight=weight, last_seen=seen)


def new_memory(config, fps: float, origin: int = 0) -> ExemplarMemory:
    """An empty memory for a stream at ``fps`` whose first relabel window begins at frame
    ``origin``."""
    return ExemplarMemory(stride=max(1, int(round(fps / config.rate_hz))), origin=int(origin))


def _runs(segments):
    """Maximal runs ``(start, end, id)`` of consecutive segments with one id."""
    out = []
    for a, b, lab in sorted((int(a), int(b), int(c)) for a, b, c in segments):
        if out and out[-1][2] == lab and out[-1][1] == a:
            out[-1] = (out[-1][0], b, lab)
        else:
            out.append((a, b, lab))
    return out
