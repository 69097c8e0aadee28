"""Stream-wide action ids for successive relabels of one stream, with bounded memory.

Each relabel clusters a window of the stream's history on its own; its cluster ids mean
nothing outside it. :func:`stable_labels` turns them into ids that mean the same action for
the life of the stream, in two steps:

1. **Overlap.** Clusters are matched to the previous revision's ids by the Hungarian matching
   of the frames both windows cover (:func:`streamseg.offline.relabel.match_labels`).
2. **Memory.** A cluster that no overlap explains (an action that comes back after the window
   has moved past its last occurrence) is compared with the stream's *prototypes*: for every
   id seen so far, the mean feature vector of its frames in the last revision that held it.
   It takes the id of the nearest prototype not already used in this window when that
   prototype lies inside the cluster's own spread (nearer to its mean than the RMS distance
   of its frames to it), else a new id. The scale is the data's own: no threshold to tune.

Memory per stream: at most :data:`MAX_PROTOTYPES` prototypes of ``d + 3`` numbers (the least
recently seen is dropped first): 32 x 20 x 8 bytes = 5 kB for the 17 cut features.

:func:`snap_to_cuts` makes the relabel and the live cuts one answer: a boundary between two
actions moves to a live cut within ``radius`` frames, so a revision does not place the same
change a few frames away from the cut it supersedes.
"""

from __future__ import annotations

import numpy as np

#: Prototypes kept per stream (ids of actions not seen for longest are forgotten first).
MAX_PROTOTYPES = 32


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


def _means(segs, start, end, features, frames):
    """id -> (mean feature vector, frame count, RMS distance of its frames to the mean)."""
    lab = frame_labels(start, end, segs)[frames - start]
    out = {}
    for u in np.unique(lab[lab >= 0]):
        rows = features[lab == u]
        mean = rows.mean(axis=0)
        out[int(u)] = (mean, rows.shape[0], float(np.sqrt(((rows - mean) ** 2).sum(1).mean())))
    return out


def _from_memory(mapping, fresh, means, prototypes):
    """Give clusters with a fresh id the id of a matching prototype (module docstring)."""
    taken = set(mapping.values()) - {mapping[c] for c in fresh}
    pairs = sorted((float(np.linalg.norm(means[c][0] - mean)), c, lab)
                   for c in fresh if c in means for lab, mean, _n, _t in prototypes
                   if lab not in taken)
    done = set()
    for dist, c, lab in pairs:
        if dist < means[c][2] and c not in done and lab not in taken:
            mapping[c] = lab
            taken.add(lab)
            done.add(c)
    return mapping


def stable_labels(window, previous, features=None, frames=None):
    """``window`` with cluster ids matched to ``previous``'s, then to the stream's memory.

    Parameters
    ----------
    window : WindowSegmentation
        This revision, in stream frames, with its own cluster ids.
    previous : WindowSegmentation or None
        The stream's previous revision (stable ids, and the prototypes).
    features : (m, d) array, optional
        The rows the revision clustered; with ``frames`` they update the prototypes and
        let a returning action find its old id.
    frames : (m,) int array, optional
        Stream frame of each row.

    Returns
    -------
    WindowSegmentation with stable ids, ``n_clusters`` of ``window`` and the updated
    prototypes.
    """
    from streamseg.offline.relabel import WindowSegmentation, match_labels

    segs = [(int(a), int(b), int(c)) for a, b, c in window.segments]
    protos = tuple(previous.prototypes) if previous is not None else ()
    if not segs:
        return WindowSegmentation(window.start, window.end, segs, window.n_clusters, protos)
    means = (_means(segs, window.start, window.end, np.asarray(features, dtype=np.float64),
                    np.asarray(frames, dtype=np.int64))
             if features is not None and len(features) else {})
    new_ids = {lab for _, _, lab in segs}
    if previous is None:
        mapping = {u: u for u in new_ids}
        fresh = set()
    else:
        new = frame_labels(window.start, window.end, segs)
        old_segs = [(int(a), int(b), int(c)) for a, b, c in previous.segments]
        old = frame_labels(previous.start, previous.end, old_segs)
        lo, hi = max(window.start, previous.start), max(min(window.end, previous.end), 0)
        a = new[lo - window.start:max(hi, lo) - window.start]
        b = old[lo - previous.start:max(hi, lo) - previous.start]
        both = (a >= 0) & (b >= 0)  # frames neither window skipped (missing frames are -1)
        used = {lab for _, _, lab in old_segs} | {lab for lab, *_ in protos}
        mapping = match_labels(a[both], b[both], used, new_ids=new_ids)
        old_here = set(b[both].tolist())
        fresh = {u for u in new_ids if mapping[u] not in old_here}  # no overlap explains it
        mapping = _from_memory(mapping, fresh, means, protos)
    out = [(a, b, mapping[lab]) for a, b, lab in segs]
    # memory: this revision's look of each of its actions, then the others, newest first
    here = {mapping[u]: (m, n) for u, (m, n, _r) in means.items()}
    kept = [(lab, m, n, window.end) for lab, (m, n) in here.items()]
    kept += [p for p in protos if p[0] not in here]
    kept.sort(key=lambda p: -p[3])
    return WindowSegmentation(window.start, window.end, out, window.n_clusters,
                              tuple(kept[:MAX_PROTOTYPES]))
