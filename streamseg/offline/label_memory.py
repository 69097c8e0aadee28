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

At the next relabel the exemplars of every remembered id that the previous revision does not
show inside the new window are appended to the window (:func:`fit_with_exemplars`) and
clustered *with* it, by the same (H)ACA fit, kernel and bandwidth (the bandwidth rule then
sees the exemplar frames too): the DTAK compares the new segments with the old ones inside
one clustering (each cluster against the others), instead of against an absolute threshold,
which is what made the earlier prototype memory fail (the identity module's docstring). The
number of actions is searched in ``[2, k_max + n]`` for ``n`` appended ids, since the window
may hold ``k_max`` actions besides them, and the silhouette that picks K sees the exemplars'
pieces like the window's. An id votes for the cluster holding more than half of its exemplar
frames; a window cluster the overlap does not explain then takes the voted id with the most
exemplar frames in it (:func:`streamseg.offline.identity.stable_labels`); a cluster without
exemplars or overlap gets a new id.

The joins between the window and the exemplars, and between exemplars, are abrupt; a
segment of the fit that straddles one is cut there (window segments end at the window's end).

While the window still begins at the stream's first frame nothing is appended: a take within
the history is relabelled exactly as without the memory (tested).

Measured (``benchmarks/label_memory.py``; the settings were chosen on ret_14_86_14 and
ret_hdm_bd among per_id 1-3 and exemplar_s 1.5-3 s): see the identity module's docstring.
It is off by default in the daemon.

Memory per stream: at most ``LabelMemoryConfig.max_bytes(d)`` (130 kB for 17 features with
the defaults). A relabel with n remembered ids absent from the window clusters up to
``n * per_id * exemplar_s`` seconds more frames (at most 64 s with the defaults; the
relabel's median time on the return streams went from 0.25-0.60 s to 0.34-1.22 s on the
shared machine).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np


@dataclass
class ExemplarMemory:
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
        there, nothing has left the history and the memory stays out of the fit.
    """

    stride: int = 1
    exemplars: dict = field(default_factory=dict)
    weight: dict = field(default_factory=dict)
    last_seen: dict = field(default_factory=dict)
    origin: int = 0

    @property
    def nbytes(self) -> int:
        """Bytes held by the exemplar frames."""
        return int(sum(a.nbytes for ex in self.exemplars.values() for a in ex))

    def absent(self, previous_segments, window_start: int) -> list:
        """Remembered ids with no frame at or after ``window_start`` in the previous revision's
        ``previous_segments`` (the ones the overlap cannot carry into the new window)."""
        if window_start <= self.origin:
            return []  # the window holds the whole stream: the overlap carries every id
        present = {int(lab) for _, e, lab in previous_segments if int(e) > window_start}
        return sorted(i for i in self.exemplars if i not in present)

    def pieces(self, ids) -> list:
        """``[(id, (L, d) float64 frames), ...]`` for ``ids``, back at the stream's frame rate
        (each kept frame repeated ``stride`` times)."""
        out = []
        for i in ids:
            for a in self.exemplars.get(i, ()):
                out.append((int(i), np.repeat(a.astype(np.float64), self.stride, axis=0)))
        return out

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
                rows = np.asarray(features[mid - half:mid + half:self.stride], dtype=np.float32)
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
            for lab in order[:len(ex) - config.max_ids]:
                ex.pop(lab)
                weight.pop(lab, None)
        seen = {i: seen[i] for i in ex}
        return ExemplarMemory(self.stride, ex, weight, seen, self.origin)


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


def fit_with_exemplars(X, pieces, config, fps: float):
    """(H)ACA of the window ``X`` (n, d) clustered together with exemplar ``pieces``.

    Parameters
    ----------
    X : (n, d) array
    pieces : list of (id, (L, d) array), from :meth:`ExemplarMemory.pieces`
    config : ACAConfig
    fps : float

    Returns
    -------
    fitted : model_selection.Fitted
        Labels and segments of the window's ``n`` rows only (segments cut at ``n``).
    votes : dict
        Window cluster -> {stream id: exemplar frames}: for each id, the cluster holding more
        than half of its exemplar frames (ids without such a cluster do not vote).
    """
    from streamseg.offline.model_selection import Fitted, fit_aca

    X = np.asarray(X, dtype=np.float64)
    n = X.shape[0]
    if not pieces:
        return fit_aca(X, config, fps), {}
    ids = sorted({i for i, _ in pieces})
    cfg = config if config.n_clusters is not None else replace(
        config, k_max=config.k_max + len(ids))
    Xc = np.vstack([X] + [p for _, p in pieces])
    fitted = fit_aca(Xc, cfg, fps)
    labels = np.asarray(fitted.labels_)
    counts: dict = {}
    o = n
    for i, p in pieces:
        lab = np.bincount(labels[o:o + p.shape[0]], minlength=labels.max() + 1)
        counts[i] = counts.get(i, 0) + lab
        o += p.shape[0]
    window_clusters = set(np.unique(labels[:n]).tolist())
    votes: dict = {}
    for i, c in counts.items():
        best = int(np.argmax(c))
        if best in window_clusters and c[best] * 2 > c.sum():
            votes.setdefault(best, {})[i] = int(c[best])
    segs = [(s, min(e, n), lab) for s, e, lab in fitted.segments_ if s < n]
    k = len(np.unique(labels[:n]))
    out = Fitted(labels[:n].copy(), segs, k, fitted.scores_, fitted.objective_, fitted.reason)
    return out, votes
