"""Stream-wide action ids for successive relabels of one stream, in constant memory.

Each relabel clusters a window of the stream's history on its own; its cluster ids mean
nothing outside it. :func:`stable_labels` maps them onto the stream's ids: a cluster takes the
id of the previous revision's cluster it shares most frames with (Hungarian matching of the
frames both windows cover), and a cluster no overlap explains takes a new id, never one the
stream has used before (the stream keeps one counter), so an id means one action for the
life of the stream. A take no longer than the history (``DaemonConfig.relabel_history``,
60 s) is relabelled whole every revision, so all its actions keep their ids.

An action that returns after the window has moved past its last occurrence has no overlap to
carry its id, and gets a new one. The exemplar memory (``DaemonConfig.label_memory``, off by
default; :mod:`streamseg.offline.label_memory`) clusters a few feature segments of each
remembered id with every window once the window has left the stream's start, and a cluster
the overlap does not explain takes the id whose exemplars it holds (``votes`` of
:func:`stable_labels`). Measured on five streams whose actions return after the 60 s history
(``benchmarks/label_memory.py``, revisions of the daemon's job function every 5 s; the
settings chosen on ret_14_86_14 and ret_hdm_bd), whole-stream frame accuracy without / with
the memory, and the share of returning frames that keep their first id:

* tuning streams: ret_14_86_14 0.633 / 0.743 (0 / 0.376), ret_hdm_bd 0.620 / 0.738 (0 / 0.617);
* held out: ret_86_14_14_86 0.718 / 0.791 (0 / 0.947), ret_hdm_bk 0.554 / 0.514
  (0 / 0.315), ret_hdm_dg 0.728 / 0.639 (0.243 / 0).

The real daemon at real time (``--daemon 1``: live cuts move boundaries, revisions are timed
by arrival) gave other figures: ret_14_86_14 0.636 / 0.735 (0 / 0.331), ret_hdm_bd 0.621 /
0.601 (0 / 0), ret_86_14_14_86 0.727 / 0.661 (0 / 0.373), ret_hdm_bk 0.507 / 0.570 (0 / 0),
ret_hdm_dg 0.733 / 0.677 (0.276 / 0); mean 0.645 / 0.649 (0.055 / 0.141).

It does not generalise reliably, hence off: a new action can take an old id when the
clustering puts it with old exemplars (toe touches took the squats' id for a while), and the
exemplars change the window's own clustering (K is searched up to ``k_max`` plus the number of
appended ids), for better or worse. A variant that also appends exemplars while the window
still holds the whole stream (of ids a revision dropped) raised the accuracy on all five
streams (mean 0.651 to 0.712; returning share 0.551) but lowered live 14_20 from 0.872 to
0.770 in ``benchmarks/live_relabel.py --speeds 4``, so it was not kept. Its results moved a
lot with small changes (on the tuning streams, one exemplar per id instead of two: 0.853 and
0.635 against 0.774 and 0.738; exemplars of 1.5 s or 3 s: 0.711 / 0.601 and 0.713 / 0.619).

An earlier memory was measured and left out (revisions simulated every 5 s over the last
20 s of CMU 14_14, whose six actions never return): prototypes of each id (its mean
features and spread), matched when a new cluster lay within their spread, merged arm circles
into jumping jacks (frame accuracy 0.886 without the memory, 0.788 with it), and recognised
neither a returning jumping jack nor a returning jog appended to the take; DTAK prototypes
either merged the same way (the nearest of the old and current clusters) or never matched
(within the cluster's own DTAK spread): the window's Gaussian kernel is too local to compare a
segment with one from long ago by an absolute threshold. Clustering the exemplars with the
window compares them with the window's clusters instead.

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
        out[max(a, start) - start:min(b, end) - start] = lab
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
        a = new[lo - window.start:max(hi, lo) - window.start]
        b = old[lo - previous.start:max(hi, lo) - previous.start]
        both = (a >= 0) & (b >= 0)  # frames neither window skipped (missing frames are -1)
        seen = max(previous.next_id, 1 + max((lab for _, _, lab in old_segs), default=-1))
        # every id the stream has used is taken: a new cluster gets the next one
        mapping = match_labels(a[both], b[both], set(range(seen)), new_ids=new_ids)
        next_id = max([seen] + [v + 1 for v in mapping.values()])
    out = [(a, b, mapping[lab]) for a, b, lab in segs]
    return WindowSegmentation(window.start, window.end, out, window.n_clusters, next_id)
