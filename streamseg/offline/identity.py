"""Stream-wide action ids for successive relabels of one stream, in constant memory.

Each relabel clusters a window of the stream's history on its own; its cluster ids mean
nothing outside it. :func:`stable_labels` maps them onto the stream's ids: a cluster takes the
id of the previous revision's cluster it shares most frames with (Hungarian matching of the
frames both windows cover), and a cluster no overlap explains takes a new id, never one the
stream has used before (the stream keeps one counter), so an id means one action for the
life of the stream. A take no longer than the history (``DaemonConfig.relabel_history``,
60 s) is relabelled whole every revision, so all its actions keep their ids.

An action that returns after the window has moved past its last occurrence has no overlap to
carry its id. The label memory (``DaemonConfig.label_memory``, on by default;
:mod:`streamseg.offline.label_memory`, :mod:`streamseg.offline.recall`) keeps a few exemplar
segments of each id and, after this matching, lets a cluster the overlap does not explain
take a remembered id the revision does not hold, on DTAK evidence relative to the data; the
window's clustering is the one without memory.

The exemplars stay out of the window's clustering, and the test is relative, because clustering
them with the window let a new action take an old id and an absolute DTAK threshold does not fit
the window's local kernel (``docs/decisions.md``, Labels).

:func:`snap_to_cuts` makes the relabel and the live cuts one answer: a boundary between two
actions moves to a live cut within ``radius`` frames, so a revision does not place the same
change a few frames away from the cut it supersedes.
"""

from __future__ import annotations

import numpy as np


def frame_labels(start: int, end: int, segs) -> np.ndarray:
    """(end - start,) label of each frame of ``[start, end)``; -1 where no segment covers it."""
    out = np.full(end - start, -1, dtype=np.int64)
    for a, b, lab in segs:
        out[max(a, start) - start : min(b, end) - start] = lab
    return out


def snap_to_cuts(segs, cuts, radius: int) -> list:
    """Move each boundary between two differently labelled segments to the nearest of
    ``cuts`` within ``radius`` frames (keeping every segment non-empty).

    Parameters
    ----------
    segs : list of (start, end, label), tiling a range of stream frames
    cuts : iterable of int, live cut frames
    radius : int, frames

    Returns
    -------
    list of (start, end, label)
    """
    cuts = np.unique(np.asarray(list(cuts), dtype=np.int64))
    if cuts.size == 0 or len(segs) < 2 or radius <= 0:
        return list(segs)
    out = [list(s) for s in segs]
    for i in range(1, len(out)):
        if out[i][2] == out[i - 1][2]:
            continue
        b = out[i][0]
        j = int(np.argmin(np.abs(cuts - b)))
        c = int(cuts[j])
        if abs(c - b) <= radius and out[i - 1][0] < c < out[i][1]:
            out[i - 1][1] = out[i][0] = c
    return [tuple(s) for s in out]


def stable_labels(window, previous):
    """``window`` with its cluster ids mapped onto the stream's ids (module docstring).

    Parameters
    ----------
    window : WindowSegmentation
        This revision, in stream frames, with its own cluster ids.
    previous : WindowSegmentation or None
        The stream's previous revision (stream ids, and the stream's next free id).

    Returns
    -------
    WindowSegmentation with stream ids, ``n_clusters`` of ``window`` and the next free id.
    """
    from streamseg.offline.relabel import WindowSegmentation, match_labels

    segs = [(int(a), int(b), int(c)) for a, b, c in window.segments]
    new_ids = {lab for _, _, lab in segs}
    if previous is None:
        mapping = {u: i for i, u in enumerate(sorted(new_ids))}
        next_id = len(new_ids)
    else:
        new = frame_labels(window.start, window.end, segs)
        old_segs = [(int(a), int(b), int(c)) for a, b, c in previous.segments]
        old = frame_labels(previous.start, previous.end, old_segs)
        lo, hi = max(window.start, previous.start), max(min(window.end, previous.end), 0)
        a = new[lo - window.start : max(hi, lo) - window.start]
        b = old[lo - previous.start : max(hi, lo) - previous.start]
        both = (a >= 0) & (b >= 0)  # frames neither window skipped (missing frames are -1)
        seen = max(previous.next_id, 1 + max((lab for _, _, lab in old_segs), default=-1))
        # every id the stream has used is taken: a new cluster gets the next one
        mapping = match_labels(a[both], b[both], set(range(seen)), new_ids=new_ids)
        next_id = max([seen] + [v + 1 for v in mapping.values()])
    out = [(a, b, mapping[lab]) for a, b, lab in segs]
    return WindowSegmentation(window.start, window.end, out, window.n_clusters, next_id)
