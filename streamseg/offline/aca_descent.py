"""ACA's coordinate descent (Zhou et al. 2008, Algorithm 1): the DP segmentation step of eq. 9
over candidate sums (``streamseg._kernels.aca``), repeated from one initial segmentation.

Split from :mod:`streamseg.offline.aca`, which holds the estimator and its decisions.
"""

from __future__ import annotations

import numpy as np

from streamseg._kernels.aca import candidate_sums, relax
from streamseg._kernels.dtak import segment_kernel_within


def dp_step(K, starts, ends, labels, n_c, const, wmin: int, wmax: int, *, binary=None):
    """One DP segmentation step (eq. 9) under the centres of the old segmentation.

    ``K`` (n, n) is read as ``K[old frame, candidate frame]``: symmetric, or pass its
    transpose (:func:`dp_kernel`). For a 0/1 kernel the eq. 7 tables are exact narrow
    integers (:func:`work_dtype`). Returns ``(starts, ends, labels, cost)``.
    """
    F = candidate_table(K, starts, ends, labels, n_c.shape[0], wmin, wmax, binary=binary)
    return relax(F, n_c, const, wmin, wmax)


def candidate_table(
    K, starts, ends, labels, k: int, wmin: int, wmax: int, *, binary=None, frame_ids=None
):
    """``F`` (k, wmax + 1, n + 1): ``F[c, w, t]`` the sum of the DTAKs between candidate
    ``[t, t + w)`` and the old segments of cluster c (``streamseg._kernels.aca``).

    ``frame_ids`` (n,) int64, optional, for a 0/1 kernel: frames of one id have identical
    kernel rows (:func:`frame_ids`); old segments of one label whose frames have the same
    ids have the same DTAK with every candidate, so each such group is computed once and
    counted as many times (exactly: the sums are integers until the division).
    """
    n = K.shape[0]
    if binary is None:
        binary = bool(np.all((K == 0) | (K == 1)))
    # longest first, then by label: runs of one (length, label) are summed before dividing
    order = np.lexsort((labels, starts - ends))
    starts, ends, labels = starts[order], ends[order], labels[order]
    dtype = work_dtype(binary, int((ends - starts).max()), wmax)
    counts = np.ones(starts.shape[0], np.int64)
    if frame_ids is not None and dtype != np.float64:
        starts, ends, labels, counts = _identical_merged(starts, ends, labels, frame_ids)
    if dtype != np.float64 and K.dtype not in (np.int8, np.int16):
        K = K.astype(np.int8)  # callers in a loop pass it converted once (dp_kernel)
    A = np.empty((wmax + 1, n + 1), dtype)
    B = np.empty((wmax + 1, n + 1), dtype)
    acc = np.empty((wmax + 1, n + 1), np.float64 if dtype == np.float64 else np.int64)
    F = np.zeros((k, wmax + 1, n + 1))
    candidate_sums(K, starts, ends, labels, counts, wmin, wmax, A, B, acc, F, NEG[dtype])
    return F


def _identical_merged(starts, ends, labels, frame_ids):
    """The old segments (sorted by length, then label) with each group of one length, label
    and frame ids kept once, in place of its first, and its size: ``(starts, ends, labels,
    counts)``; the order of (length, label) runs is unchanged."""
    ids = np.asarray(frame_ids)
    m = starts.shape[0]
    lens = ends - starts
    width = int(lens.max()) if m else 0
    # one row per segment: length, label, its frames' ids (padded with -1); equal rows are
    # one group, kept at its first segment (np.unique gives each group's first index)
    rows = np.full((m, width + 2), -1, dtype=np.int64)
    rows[:, 0] = lens
    rows[:, 1] = labels
    offset = np.arange(width)
    inside = offset[None, :] < lens[:, None]
    rows[:, 2:][inside] = ids[(starts[:, None] + offset[None, :])[inside]]
    _, first, group = np.unique(rows, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    keep = first[order]
    counts = np.bincount(group.reshape(-1), minlength=first.shape[0])[order]
    return starts[keep], ends[keep], labels[keep], counts.astype(np.int64)


def frame_ids(K, limit: int | None = None):
    """(n,) int64: frames with identical rows of ``K`` (n, n) share an id (ids in order of
    first appearance). For the equality kernel these are the frames of one value. None
    once more than ``limit`` distinct rows are found (when a limit is given)."""
    K = np.ascontiguousarray(K)
    ids = np.empty(K.shape[0], dtype=np.int64)
    seen: dict = {}
    for i in range(K.shape[0]):
        ids[i] = seen.setdefault(K[i].tobytes(), len(seen))
        if limit is not None and len(seen) > limit:
            return None
    return ids


#: the -inf of each work dtype of the DP tables (exact ranges: :func:`work_dtype`)
NEG = {np.int8: np.int8(-64), np.int16: np.int16(-16000), np.float64: -np.inf}


def work_dtype(binary: bool, lmax: int, wmax: int):
    """The narrowest exact dtype of the DP tables: for a 0/1 kernel every entry is an
    integer at most ``lmax + wmax`` (see ``streamseg._kernels.aca.candidate_sums``)."""
    if not binary or lmax + wmax >= 4000:
        return np.float64
    return np.int8 if lmax + wmax <= 60 else np.int16


def dp_kernel(K, binary: bool):
    """K as every DP step reads it, prepared once per fit: a 0/1 kernel as int8; a float
    kernel as its transpose unless it is exactly symmetric (rows = old frames)."""
    if binary:
        return K.astype(np.int8, copy=False)
    return K if np.array_equal(K, K.T) else np.ascontiguousarray(K.T)


def _own_sums(K, K_dp, starts, ends, labels, k, wmin, wmax, binary, ids=None):
    """``F`` of the segmentation (:func:`candidate_table`) and each segment's summed DTAK
    with the segments of its own cluster, itself included (m,).

    The sums are read off ``F``, whose candidates include every old segment of a length in
    ``[wmin, wmax]``; a segment of another length (only an initial one can be) costs a row of
    within-cluster DTAKs.
    """
    F = candidate_table(K_dp, starts, ends, labels, k, wmin, wmax, binary=binary, frame_ids=ids)
    lens = ends - starts
    inside = (lens >= wmin) & (lens <= wmax)
    own = np.zeros(starts.shape[0])
    own[inside] = F[labels[inside], lens[inside], starts[inside]]
    if not inside.all():
        T = segment_kernel_within(K, starts, ends, labels)
        own[~inside] = (T[~inside] * (labels[~inside, None] == labels[None, :])).sum(1)
    return F, own


def descend(
    K,
    starts,
    ends,
    labels,
    k: int,
    wmin: int,
    wmax: int,
    max_iter: int,
    *,
    binary=None,
    K_dp=None,
    ids=None,
):
    """Coordinate descent from one initial segmentation on frame kernel ``K`` (n, n).

    ``binary``: whether K is 0/1 (computed when None); ``K_dp``: K as the DP step reads it
    (:func:`dp_kernel`; prepared here when None); ``ids``: :func:`frame_ids` of a 0/1 K,
    old segments of identical frames then computed once (:func:`candidate_table`; the same
    answer).
    Returns ``(starts, ends, labels, objective, n_iter)``.

    One table of candidate sums per step: the cluster statistics (``h_c``), the objective and
    the re-seeding of empty clusters all come from the segments' own sums in it (the self-DTAK
    of a segment is 1 under a unit-diagonal kernel), so no segment DTAK matrix is built.
    """
    starts = np.ascontiguousarray(starts, dtype=np.int64)
    ends = np.ascontiguousarray(ends, dtype=np.int64)
    labels = np.ascontiguousarray(labels, dtype=np.int64)
    if binary is None:
        binary = bool(np.all((K == 0.0) | (K == 1.0)))
    if K_dp is None:
        K_dp = dp_kernel(K, binary)

    def prepared(starts, ends, labels):
        """Labels with empty clusters re-seeded, the candidate table and own sums."""
        F, own = _own_sums(K, K_dp, starts, ends, labels, k, wmin, wmax, binary, ids)
        while True:
            counts = np.bincount(labels, minlength=k)
            empty = np.flatnonzero(counts == 0)
            movable = counts[labels] >= 2
            if empty.size == 0 or not movable.any():
                return labels, F, own
            n_c, const = _stats(own, labels, k)
            dist = 1.0 - 2.0 * own / n_c[labels] + const[labels]
            dist[~movable] = -np.inf
            labels = labels.copy()
            labels[int(np.argmax(dist))] = empty[0]
            F, own = _own_sums(K, K_dp, starts, ends, labels, k, wmin, wmax, binary, ids)

    labels, F, own = prepared(starts, ends, labels)
    it = 0
    while it < max_iter:
        it += 1
        n_c, const = _stats(own, labels, k)
        ns, ne, nl, _ = relax(F, n_c, const, wmin, wmax)
        if (
            ns.shape == starts.shape
            and np.array_equal(ns, starts)
            and np.array_equal(ne, ends)
            and np.array_equal(nl, labels)
        ):
            break
        starts, ends = ns, ne
        labels, F, own = prepared(ns, ne, nl)
    n_c, const = _stats(own, labels, k)
    return starts, ends, labels, float(np.sum(1.0 - 2.0 * own / n_c[labels] + const[labels])), it


def _stats(own, labels, k):
    """``n_c`` (k,) and ``h_c / n_c**2`` (k,) from the segments' own sums (``h_c`` is their
    sum over the cluster); as :func:`cluster_stats`."""
    n_c = np.bincount(labels, minlength=k).astype(np.float64)
    h = np.bincount(labels, weights=own, minlength=k)
    const = np.divide(h, n_c**2, out=np.zeros(k), where=n_c > 0)
    return n_c, const
