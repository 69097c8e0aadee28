"""Post-hoc recall: a cluster of a revision takes a remembered id only on strong evidence.

The window is clustered exactly as without a memory (the fit never sees the exemplars, so the
memory cannot change the window's segmentation). The overlap with the previous revision then
carries ids (:func:`streamseg.offline.identity.stable_labels`). A *candidate* is a cluster
whose id the overlap does not explain: a fresh id, or one given fresh by one of the last
``recall_within - 1`` revisions (a returning action first shows as a short tail of the
window; later revisions give it more frames). Such a young id, once recalled, is replaced by
the old one in that and every later revision and never used again. Each candidate is
compared with every remembered id the revision does not hold
(:class:`streamseg.offline.label_memory.ExemplarMemory`) by the DTAK (the window's Gaussian
frame kernel and bandwidth) between pieces of the candidate's segments and the id's
exemplars, all at the memory's frame rate and at most ``exemplar_s`` long:

* ``cross(c, j)``: mean DTAK between c's pieces and j's exemplars;
* ``own(c)``: mean DTAK between two different pieces of c; ``own(j)``: between two different
  exemplars of j;
* ``ratio(c, j) = cross(c, j) / max(own(c), own(j))``: 1 when c is as close to j's exemplars
  as c's pieces are to each other and j's exemplars to each other.

c may take j when ``ratio(c, j) >= recall_ratio`` and ``ratio(c, j)`` exceeds c's ratio to
every other remembered id (absent or not) by ``recall_margin``; the thresholds are relative to
the data (an absolute DTAK threshold failed: the kernel is local, the values vary with the
window). Candidates and ids are then paired one to one (Hungarian on the ratio); a candidate
without a pair keeps (or gets) a new id. With ``recall_confirm = 2`` a pair is only taken when
the previous revision proposed the same pair (the candidate's id carried by the overlap).

With ``merge_present`` (on by default, :class:`~streamseg.config.memory.LabelMemoryConfig`) a
candidate not recalled may also join an id the revision holds, on the same relative test against
that id's exemplars (:func:`merge_into_present`), when one of its runs touches one of that id's
runs in the revision (``merge_adjacent``): two clusters of one revision then share an id, which
cuts the commonest source of extra ids (a revision splitting one action in two). It adds no
state. Why these tests and thresholds, with the figures: ``docs/decisions.md`` (Labels, the
label memory).

Kept as plain values (the checkpoint codec stores them): the memory's ``born`` (id -> the
revision that first gave it) and ``pending`` (candidate id -> proposed old id).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from streamseg._kernels.dtak import dtak_pair
from streamseg.offline.dtak import default_sigma, frame_kernel


def pieces_of(segments, label, features, frames, keep: int, stride: int, max_pieces: int):
    """Up to ``max_pieces`` pieces (each at most ``keep`` rows before striding) of the runs of
    ``label`` in ``segments`` (stream frames), longest runs first; a single piece is halved,
    so two pieces can be compared. Returns a list of (L, d) float64 arrays (L >= 2)."""
    from streamseg.offline.label_memory import _runs

    runs = sorted(
        ((a, b) for a, b, lab in _runs(segments) if lab == label), key=lambda r: r[0] - r[1]
    )
    out = []
    for a, b in runs:
        r0, r1 = (int(x) for x in np.searchsorted(frames, [a, b]))
        n = r1 - r0
        if n < 4 * stride:
            continue
        parts = max(1, int(round(n / keep)))
        bounds = np.linspace(r0, r1, parts + 1).astype(np.int64)
        for p0, p1 in zip(bounds[:-1], bounds[1:], strict=True):
            mid, half = (p0 + p1) // 2, min(keep, p1 - p0) // 2
            out.append(np.asarray(features[mid - half : mid + half : stride], dtype=np.float64))
            if len(out) >= max_pieces:
                break
        if len(out) >= max_pieces:
            break
    if len(out) == 1 and out[0].shape[0] >= 4:
        h = out[0].shape[0] // 2
        out = [out[0][:h], out[0][h:]]
    return [p for p in out if p.shape[0] >= 2 and np.isfinite(p).all()]


def dtak_between(A, B, sigma: float) -> np.ndarray:
    """(len(A), len(B)) DTAK between the pieces ``A`` and ``B`` (lists of (L, d) arrays)."""
    if not A or not B:
        return np.zeros((len(A), len(B)))
    XA, XB = np.vstack(A), np.vstack(B)
    K = np.ascontiguousarray(frame_kernel(XA, XB, kernel="gaussian", sigma=sigma))
    oa = np.concatenate([[0], np.cumsum([p.shape[0] for p in A])])
    ob = np.concatenate([[0], np.cumsum([p.shape[0] for p in B])])
    row = np.empty(int(max(p.shape[0] for p in B)) + 1)
    out = np.empty((len(A), len(B)))
    for i in range(len(A)):
        for j in range(len(B)):
            out[i, j] = dtak_pair(K, oa[i], oa[i + 1], ob[j], ob[j + 1], row)
    return out


def _own(S: np.ndarray) -> float:
    """Mean off-diagonal value of a square DTAK matrix (nan below two pieces)."""
    n = S.shape[0]
    if n < 2:
        return float("nan")
    return float((S.sum() - np.trace(S)) / (n * (n - 1)))


def recall_scores(cand_pieces: dict, memory, sigma: float) -> dict:
    """``{(candidate, id): (ratio, best other ratio)}`` for every candidate and remembered id
    (module docstring); the other ids are every remembered one but ``id`` and the candidate
    itself."""
    ids = sorted(memory.exemplars)
    ex = {j: [np.asarray(a, dtype=np.float64) for a in memory.exemplars[j]] for j in ids}
    own_j = {j: _own(dtak_between(ex[j], ex[j], sigma)) for j in ids}
    out = {}
    for c, P in cand_pieces.items():
        own_c = _own(dtak_between(P, P, sigma))
        ratios = {}
        for j in ids:
            cross = float(dtak_between(P, ex[j], sigma).mean()) if ex[j] else 0.0
            ref = np.nanmax([own_c, own_j[j]]) if np.isfinite([own_c, own_j[j]]).any() else 0.0
            ratios[j] = cross / ref if ref > 0 else 0.0
        for j in ids:
            # the candidate's own exemplars (a young id remembered last revision) compete not
            other = max((r for i, r in ratios.items() if i not in (j, c)), default=0.0)
            out[c, j] = (ratios[j], other)
    return out


def touches(segments, c: int, j: int) -> bool:
    """Whether a run of id ``c`` in ``segments`` touches a run of ``j`` (one ends where the
    other begins)."""
    from streamseg.offline.label_memory import _runs

    runs = _runs(segments)
    bounds_j = {x for a, b, lab in runs if lab == j for x in (a, b)}
    return any(a in bounds_j or b in bounds_j for a, b, lab in runs if lab == c)


def merge_into_present(P: dict, hosts, scores: dict, taken, config, segments=()) -> dict:
    """Candidates that join an id the revision already holds (``merge_present``).

    A candidate ``c`` (a cluster the overlap does not explain) not recalled (``taken``) joins
    the present, established id ``j`` (in ``hosts``: remembered, not a candidate) with the
    best ratio when ``ratio(c, j) >= merge_ratio`` and ``ratio(c, j)`` exceeds c's ratio to
    every other remembered id by ``merge_margin`` (the recall's relative test). Unlike the
    recall, several candidates may join one id: two clusters of one revision then share an id
    (an action the fit split in two). Only ids change: the segments keep their bounds.

    With ``merge_adjacent`` (``segments``: the revision's), a run of ``c`` must also touch
    a run of ``j`` (:func:`touches`): the two clusters of one split action tile its frames,
    so they touch somewhere; two clusters that never touch have other clusters between them
    everywhere, and the fit of this very window put them apart.
    """
    out = {}
    adjacent = bool(getattr(config, "merge_adjacent", False))
    for c in sorted(P):
        if c in taken:
            continue
        best = None
        for j in hosts:
            if j == c or (adjacent and not touches(segments, c, j)):
                continue
            r, other = scores[c, j]
            if (
                r >= config.merge_ratio
                and r >= other + config.merge_margin
                and (best is None or r > best[0])
            ):
                best = (r, j)
        if best is not None:
            out[c] = best[1]
    return out


def recall(
    stable, previous, memory, features, frames, config, fps: float, sigma: float | None = None
):
    """Map candidates of ``stable`` onto remembered ids on strong evidence (module docstring).

    Parameters
    ----------
    stable : WindowSegmentation
        This revision in stream ids (after :func:`~streamseg.offline.identity.stable_labels`).
    previous : WindowSegmentation or None
        The previous revision (its ``next_id`` tells the fresh ids).
    memory : ExemplarMemory
        The stream's memory before this revision.
    features : (m, d) array
        The window's feature rows; ``frames`` (m,) their stream frame numbers.
    config : LabelMemoryConfig
    fps : float
    sigma : float, optional
        Gaussian bandwidth (default: :func:`~streamseg.offline.dtak.default_sigma` of the
        window's rows at the memory's frame rate).

    Returns
    -------
    stable : WindowSegmentation
        With recalled ids (fresh ids left renumbered from the previous ``next_id``).
    memory : ExemplarMemory
        With ``born``, ``pending`` and ``revisions`` updated (exemplars are updated by the
        caller, :meth:`ExemplarMemory.updated`).
    recalled : dict
        Candidate id -> remembered id taken in this revision; with ``merge_present``, also
        candidate id -> present id it joins (:func:`merge_into_present`).
    """
    from dataclasses import replace

    frames = np.asarray(frames)
    born = dict(getattr(memory, "born", {}) or {})
    pending = dict(getattr(memory, "pending", {}) or {})
    rev = int(getattr(memory, "revisions", 0) or 0)
    segs = [(int(a), int(b), int(c)) for a, b, c in stable.segments]
    present = sorted({c for _, _, c in segs})
    seen = previous.next_id if previous is not None else 0
    cands = [c for c in present if c >= seen or born.get(c, -1) >= rev - config.recall_within + 1]
    absent = [j for j in memory.exemplars if j not in present]
    merge = bool(getattr(config, "merge_present", False))
    hosts = [j for j in present if j in memory.exemplars and j not in cands]
    recalled: dict = {}
    merged: dict = {}
    proposals: dict = {}
    may_recall = bool(absent) and int(frames[0]) > memory.origin
    if previous is not None and cands and (may_recall or (merge and hosts)):
        keep = max(2, int(round(config.exemplar_s * fps)))
        P = {
            c: pieces_of(segs, c, features, frames, keep, memory.stride, config.recall_pieces)
            for c in cands
        }
        P = {c: p for c, p in P.items() if len(p) >= 2}
        scores = {}
        if P:
            if sigma is None:
                sigma = default_sigma(np.asarray(features[:: memory.stride], dtype=np.float64))
            scores = recall_scores(P, memory, sigma)
        if P and may_recall:
            cs, js = sorted(P), sorted(absent)
            W = np.full((len(cs), len(js)), -1.0)
            for a, c in enumerate(cs):
                for b, j in enumerate(js):
                    r, other = scores[c, j]
                    if r >= config.recall_ratio and r >= other + config.recall_margin:
                        W[a, b] = r
            for a, b in zip(*linear_sum_assignment(-W), strict=True):
                if W[a, b] >= 0:
                    c, j = cs[a], js[b]
                    proposals[c] = j
                    if config.recall_confirm <= 1 or pending.get(c) == j:
                        recalled[c] = j
        if P and merge:
            merged = merge_into_present(P, hosts, scores, set(recalled), config, segs)
    mapping = {c: c for c in present}
    mapping.update(recalled)
    mapping.update(merged)
    fresh = [c for c in present if c >= seen and c not in recalled and c not in merged]
    for k, c in enumerate(fresh):
        mapping[c] = seen + k
    next_id = seen + len(fresh)
    out = [(a, b, mapping[c]) for a, b, c in segs]
    for c in present:
        born.setdefault(mapping[c], rev)
    for j in recalled.values():
        born[j] = -1  # an old id: never a candidate again
    gone = set(recalled) | set(merged)
    keep_ids = ({mapping[c] for c in present} | set(memory.exemplars)) - gone
    born = {i: r for i, r in born.items() if i in keep_ids}
    pending = {mapping[c]: j for c, j in proposals.items() if c not in gone}
    # a young id merged into an old one is gone for good: forget its exemplars too (else they
    # would compete with the old id's, or be recalled in its place)
    ex = {i: v for i, v in memory.exemplars.items() if i not in gone}
    weight = {i: v for i, v in memory.weight.items() if i not in gone}
    last_seen = {i: v for i, v in memory.last_seen.items() if i not in gone}
    memory = replace(
        memory,
        exemplars=ex,
        weight=weight,
        last_seen=last_seen,
        born=born,
        pending=pending,
        revisions=rev + 1,
    )
    return replace(stable, segments=out, next_id=next_id), memory, {**recalled, **merged}
