"""Local Outlier Factor with cosine distance: batch and incremental (numba). Private.

Semantics follow scikit-learn's ``LocalOutlierFactor``: each point has exactly
``min(k, n - 1)`` neighbours (itself excluded), ``lrd = 1 / (mean reach-dist + 1e-10)`` so held
poses (identical windows) give finite values, and ``LOF = mean(lrd(o)) / lrd(p)``. Ties in
distance are broken by age (sequence number), so the neighbour lists, and the order of every
floating-point sum, are identical in the batch and the incremental kernels.

Incremental updates follow Pokrajac, Lazarevic, Latecki (2007): after inserting or deleting a
point only the points whose k-neighbour list changed (set A), whose lrd depends on a changed
k-distance (B = A + points with a neighbour in A) and whose LOF depends on a changed lrd
(C = B + points with a neighbour in B) are recomputed. The streaming detector evicts and
inserts before one update (:func:`ext_evict` then :func:`ext_insert`): B and C are derived
from the final lists, so the values are those of two separate updates.
"""

from __future__ import annotations

import numpy as np
from numba import njit

LRD_EPS = 1e-10  # scikit-learn's guard in lrd, keeps LOF finite for duplicates


@njit(cache=True, nogil=True, inline="always")
def _cosdist(x, i, y, j, ni, nj):
    """``1 - cos`` of rows ``x[i]``, ``y[j]`` with squared norms ``ni``, ``nj`` (1 if one is 0)."""
    dot = 0.0
    for d in range(x.shape[1]):
        dot += float(x[i, d]) * float(y[j, d])
    den = np.sqrt(ni * nj)
    if den == 0.0:
        return 1.0
    r = 1.0 - dot / den
    if r < 0.0:
        return 0.0
    return r


@njit(cache=True, nogil=True, inline="always")
def _insert_sorted(idx, dist, keys, cnt, k, q, dq, kq):
    """Insert neighbour ``q`` (distance ``dq``, tie key ``kq``) into a sorted list of ``cnt``.

    Returns the new count (at most k). The caller guarantees ``q`` belongs in the list.
    """
    pos = cnt if cnt < k else k - 1
    while pos > 0 and (dist[pos - 1] > dq or (dist[pos - 1] == dq and keys[pos - 1] > kq)):
        if pos < k:
            idx[pos] = idx[pos - 1]
            dist[pos] = dist[pos - 1]
            keys[pos] = keys[pos - 1]
        pos -= 1
    idx[pos] = q
    dist[pos] = dq
    keys[pos] = kq
    return cnt + 1 if cnt < k else k


@njit(cache=True, nogil=True)
def lof_batch(x, k, centres, excl):
    """LOF of every row of ``x`` (cosine distance, neighbours tie-broken by row index).

    Parameters
    ----------
    x : float (n, d)
    k : int
    centres : int64 (n,)
        Time (frame) of each row.
    excl : int
        Rows closer in time than ``excl`` are not each other's neighbours (0: plain LOF).

    Returns
    -------
    lof, lrd, kdist : float64 (n,)
    nn : int64 (n, kk), neighbour indices nearest first (first ``cnt[i]`` valid)
    cnt : int64 (n,), neighbours of each row: ``min(k, n - 1)`` without exclusion
    """
    n = x.shape[0]
    kk = min(k, n - 1) if n > 1 else 0
    if excl > 0:
        kk = k
    norms = np.empty(n)
    for i in range(n):
        s = 0.0
        for d in range(x.shape[1]):
            s += float(x[i, d]) * float(x[i, d])
        norms[i] = s
    dm = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1, n):
            v = _cosdist(x, i, x, j, norms[i], norms[j])
            dm[i, j] = v
            dm[j, i] = v
    nn = np.zeros((n, kk), dtype=np.int64)
    nd = np.zeros((n, kk))
    keys = np.zeros(kk, dtype=np.int64)
    cnts = np.zeros(n, dtype=np.int64)
    for i in range(n):
        cnt = 0
        for j in range(n):
            if j == i or abs(centres[i] - centres[j]) < excl:
                continue
            dj = dm[i, j]
            if cnt < kk or dj < nd[i, kk - 1]:
                cnt = _insert_sorted(nn[i], nd[i], keys, cnt, kk, j, dj, j)
        cnts[i] = cnt
    kdist = np.zeros(n)
    lrd = np.empty(n)
    lof = np.ones(n)
    for i in range(n):
        if cnts[i] > 0:
            kdist[i] = nd[i, cnts[i] - 1]
    for i in range(n):
        c = cnts[i]
        if c == 0:
            lrd[i] = 1.0 / LRD_EPS
            continue
        s = 0.0
        for t in range(c):
            o = nn[i, t]
            r = nd[i, t]
            if kdist[o] > r:
                r = kdist[o]
            s += r
        lrd[i] = 1.0 / (s / c + LRD_EPS)
    for i in range(n):
        c = cnts[i]
        if c == 0:
            continue
        s = 0.0
        for t in range(c):
            s += lrd[nn[i, t]] / lrd[i]
        lof[i] = s / c
    return lof, lrd, kdist, nn, cnts


# ---- incremental LOF over a ring buffer ------------------------------------------------------
# State (one set per stream), capacity N slots, candidate lists of length K >= k:
#   centres int64 (N,) time of each point (frames), for the exclusion zone;
#   vecs int16 (N, d) integer counts (any integer dtype; int16 with columns * window**2 < 2**31
#   lets :func:`_distances_to` sum in int32); norms float64 (N,); seqs int64 (N,) (-1 = empty);
#   nn_idx int (N, K) slots; nn_d float64 (N, K); nn_key int64 (N, K) neighbour seqs;
#   nn_cnt int64 (N,) list lengths; trunc uint8 (N,) 1 if an eligible point is missing from
#   the list; lrd, lof float64 (N,); mark int64 (N,) scratch.
# Each list holds the exact nearest nn_cnt[p] points in (distance, seq) order; the first
# min(k, nn_cnt[p]) are the k-neighbours. The K - k extra candidates let an eviction shorten a
# list instead of forcing a rescan of the buffer: a rescan is needed only when a truncated list
# falls below k. A list is never truncated below k, so when it is shorter it is complete.


@njit(cache=True, nogil=True, inline="always")
def _dot_counts(vecs, i, j):
    """Dot product of two count rows; exact (integers), so equal to the float sum."""
    dot = 0
    for d in range(vecs.shape[1]):
        dot += np.int64(vecs[i, d]) * np.int64(vecs[j, d])
    return float(dot)


@njit(cache=True, nogil=True, inline="always")
def _cosdist_counts(vecs, i, j, ni, nj):
    """:func:`_cosdist` of two count rows, the same float operations on the same values."""
    dot = _dot_counts(vecs, i, j)
    den = np.sqrt(ni * nj)
    if den == 0.0:
        return 1.0
    r = 1.0 - dot / den
    if r < 0.0:
        return 0.0
    return r


@njit(cache=True, nogil=True)
def _kdist(nn_d, nn_cnt, o, k):
    c = min(nn_cnt[o], k)
    if c == 0:
        return 0.0
    return nn_d[o, c - 1]


@njit(cache=True, nogil=True)
def _update_lrd_lof(seqs, nn_idx, nn_d, nn_cnt, lrd, lof, mark, k):
    """Recompute lrd for B and LOF for C, given ``mark[p] == 1`` for the changed set A.

    Marks: 1 = A (k-neighbour list / k-distance changed), 2 = B, 3 = C. Two passes: B's
    members and their lrd (which reads the lists only), then C's members and their LOF
    (which reads the lrd of the first pass); a point marked in a pass is read by the later
    points of that pass as its own kind only (2 is not A, 3 is not B), so the sets are
    those of separate passes.
    """
    n_slots = seqs.shape[0]
    # B: A plus every point with a neighbour in A (its reach-distances changed).
    for p in range(n_slots):
        if seqs[p] < 0:
            continue
        m = mark[p]
        cnt = min(nn_cnt[p], k)
        if m == 0:
            hit = False
            for t in range(cnt):  # branch-free: the marks are unpredictable
                hit |= mark[nn_idx[p, t]] == 1
            if not hit:
                continue
            mark[p] = 2
        if cnt == 0:
            lrd[p] = 1.0 / LRD_EPS
            continue
        s = 0.0
        for t in range(cnt):
            o = nn_idx[p, t]
            r = nn_d[p, t]
            ko = _kdist(nn_d, nn_cnt, o, k)
            if ko > r:
                r = ko
            s += r
        lrd[p] = 1.0 / (s / cnt + LRD_EPS)
    # C: B plus every point with a neighbour in B (its lrd ratios changed).
    n_updated = 0
    for p in range(n_slots):
        if seqs[p] < 0:
            continue
        cnt = min(nn_cnt[p], k)
        if mark[p] == 0:
            hit = False
            for t in range(cnt):
                m = mark[nn_idx[p, t]]
                hit |= (m == 1) | (m == 2)
            if not hit:
                continue
            mark[p] = 3
        n_updated += 1
        if cnt == 0:
            lof[p] = 1.0
            continue
        s = 0.0
        for t in range(cnt):
            s += lrd[nn_idx[p, t]] / lrd[p]
        lof[p] = s / cnt
    for p in range(n_slots):
        mark[p] = 0
    return n_updated


@njit(cache=True, nogil=True)
def _scan(vecs, norms, seqs, nn_idx, nn_d, nn_key, nn_cnt, trunc, centres, p, excl):
    """Rebuild the candidate list of ``p`` from the whole buffer (K nearest eligible points)."""
    n_slots = seqs.shape[0]
    kk = nn_idx.shape[1]
    cnt = 0
    n_elig = 0
    dist = np.empty(n_slots)
    _distances_to(vecs, norms, p, dist)  # vectorized, the values of _cosdist_counts
    for j in range(n_slots):
        if j == p or seqs[j] < 0 or abs(centres[p] - centres[j]) < excl:
            continue
        n_elig += 1
        dj = dist[j]
        if (
            cnt < kk
            or dj < nn_d[p, kk - 1]
            or (dj == nn_d[p, kk - 1] and seqs[j] < nn_key[p, kk - 1])
        ):
            cnt = _insert_sorted(nn_idx[p], nn_d[p], nn_key[p], cnt, kk, j, dj, seqs[j])
    nn_cnt[p] = cnt
    trunc[p] = 1 if n_elig > kk else 0


@njit(cache=True, nogil=True)
def _distances_to(vecs, norms, p, out):
    """:func:`_cosdist_counts` of row ``p`` to every row (empty slots too) into ``out``, in
    two tight loops the compiler vectorizes: the integer dot products, then per pair the
    same float operations as the scalar function (so the same values). The products and
    sums stay in int32 (16 multiply-adds per instruction on int16 rows): exact for counts of
    at most ``window`` frames while ``columns * window**2 < 2**31``, which
    :class:`streamseg.online.StreamingLOFSegmenter` checks."""
    a = vecs[p]
    for j in range(vecs.shape[0]):
        b = vecs[j]
        dot = np.int32(0)
        for d in range(a.shape[0]):
            dot = np.int32(dot + np.int32(np.int32(a[d]) * np.int32(b[d])))
        out[j] = float(dot)
    ni = norms[p]
    for j in range(vecs.shape[0]):
        den = np.sqrt(ni * norms[j])
        r = 1.0 - out[j] / den if den != 0.0 else 1.0
        out[j] = r if r >= 0.0 else 0.0


@njit(cache=True, nogil=True)
def ext_insert(
    vecs,
    norms,
    seqs,
    nn_idx,
    nn_d,
    nn_key,
    nn_cnt,
    trunc,
    lrd,
    lof,
    mark,
    centres,
    slot,
    vec,
    seq,
    k,
    excl,
):
    """Insert ``vec`` with sequence number ``seq`` into the empty ``slot``; update LOF.

    Candidate lists have ``K = nn_idx.shape[1] >= k`` entries (see the state notes above);
    ``centres[slot]`` must hold the new point's time; points closer than ``excl`` in time are
    not neighbours.

    Returns the number of points whose LOF was recomputed.
    """
    n_slots = seqs.shape[0]
    kk = nn_idx.shape[1]
    s = 0.0
    for d in range(vec.shape[0]):
        vecs[slot, d] = vec[d]
        s += float(vecs[slot, d]) * float(vecs[slot, d])
    norms[slot] = s
    seqs[slot] = seq
    mark[slot] = 1
    cnt_new = 0
    n_elig = 0
    dist = np.empty(n_slots)
    _distances_to(vecs, norms, slot, dist)
    for j in range(n_slots):
        if j == slot or seqs[j] < 0 or abs(centres[slot] - centres[j]) < excl:
            continue
        n_elig += 1
        dj = dist[j]
        # the new point's own list
        if (
            cnt_new < kk
            or dj < nn_d[slot, kk - 1]
            or (dj == nn_d[slot, kk - 1] and seqs[j] < nn_key[slot, kk - 1])
        ):
            cnt_new = _insert_sorted(
                nn_idx[slot], nn_d[slot], nn_key[slot], cnt_new, kk, j, dj, seqs[j]
            )
        # the new point is the youngest, last among equal distances: it enters j's list when
        # strictly closer than its last candidate, or after it when the list is complete
        c = nn_cnt[j]
        if c == kk:
            trunc[j] = 1  # a full list leaves out the new point or its own last candidate
            if dj >= nn_d[j, kk - 1]:
                continue
        elif trunc[j] and dj >= nn_d[j, c - 1]:
            continue
        if c < k or dj < nn_d[j, k - 1]:
            mark[j] = 1  # its k-neighbours changed
        nn_cnt[j] = _insert_sorted(nn_idx[j], nn_d[j], nn_key[j], c, kk, slot, dj, seq)
    nn_cnt[slot] = cnt_new
    trunc[slot] = 1 if n_elig > kk else 0
    return _update_lrd_lof(seqs, nn_idx, nn_d, nn_cnt, lrd, lof, mark, k)


@njit(cache=True, nogil=True)
def ext_evict(
    vecs, norms, seqs, nn_idx, nn_d, nn_key, nn_cnt, trunc, lrd, lof, mark, centres, slot, k, excl
):
    """Remove the point in ``slot`` from every candidate list, marking (``mark = 1``) the
    points whose k-neighbours changed; lrd and LOF are left to the next update.

    A list that held it among its first ``k`` changed its k-neighbours; it is rescanned only
    when it was truncated and now has fewer than ``k`` candidates.
    """
    n_slots = seqs.shape[0]
    seqs[slot] = -1
    nn_cnt[slot] = 0
    trunc[slot] = 0
    lof[slot] = 0.0
    lrd[slot] = 0.0
    for p in range(n_slots):
        c = nn_cnt[p]  # 0 for empty slots
        t = c
        for u in range(c):  # no early exit: a branch-free search the compiler vectorizes
            if nn_idx[p, u] == slot:
                t = u
        if t == c:
            continue
        if t < k:
            mark[p] = 1
        for u in range(t, c - 1):
            nn_idx[p, u] = nn_idx[p, u + 1]
            nn_d[p, u] = nn_d[p, u + 1]
            nn_key[p, u] = nn_key[p, u + 1]
        nn_cnt[p] = c - 1
        if c - 1 < k and trunc[p]:
            _scan(vecs, norms, seqs, nn_idx, nn_d, nn_key, nn_cnt, trunc, centres, p, excl)


@njit(cache=True, nogil=True)
def ext_rebuild(
    vecs, norms, seqs, nn_idx, nn_d, nn_key, nn_cnt, trunc, lrd, lof, mark, centres, k, excl
):
    """Recompute everything :func:`ext_insert` derives from ``vecs``, ``seqs`` and
    ``centres``: norms, full candidate lists (``nn_idx.shape[1]`` nearest eligible points),
    ``trunc``, lrd and LOF; the other slots' lists, lrd and LOF are zero (as after an
    eviction). The arrays must be zero on entry (fresh).

    The first ``k`` candidates of every list are the exact ``k`` nearest (ties by age) in the
    incremental state as in this one, and lrd/LOF sum the same values in the same order, so
    the result equals the incrementally maintained state in lrd and LOF bit for bit and in
    every later update; only the candidates beyond ``k`` may differ (they are then complete).

    Returns the number of points whose LOF was computed.
    """
    n_slots = seqs.shape[0]
    for p in range(n_slots):
        if seqs[p] < 0:
            continue
        s = 0.0  # the same float operations as ext_insert
        for d in range(vecs.shape[1]):
            s += float(vecs[p, d]) * float(vecs[p, d])
        norms[p] = s
    for p in range(n_slots):
        if seqs[p] >= 0:
            _scan(vecs, norms, seqs, nn_idx, nn_d, nn_key, nn_cnt, trunc, centres, p, excl)
            mark[p] = 1
    return _update_lrd_lof(seqs, nn_idx, nn_d, nn_cnt, lrd, lof, mark, k)


@njit(cache=True, nogil=True)
def ext_delete(
    vecs, norms, seqs, nn_idx, nn_d, nn_key, nn_cnt, trunc, lrd, lof, mark, centres, slot, k, excl
):
    """:func:`ext_evict` followed by the lrd/LOF update.

    Returns the number of points whose LOF was recomputed.
    """
    ext_evict(
        vecs,
        norms,
        seqs,
        nn_idx,
        nn_d,
        nn_key,
        nn_cnt,
        trunc,
        lrd,
        lof,
        mark,
        centres,
        slot,
        k,
        excl,
    )
    return _update_lrd_lof(seqs, nn_idx, nn_d, nn_cnt, lrd, lof, mark, k)


@njit(cache=True, nogil=True)
def _trunc_of_full(nn_cnt, kk):
    # lists of exactly k (no extra candidates): a full list may be truncated, a shorter one is
    # complete (a truncated list that lost a neighbour is rescanned at once)
    t = np.zeros(nn_cnt.shape[0], dtype=np.uint8)
    for p in range(nn_cnt.shape[0]):
        if nn_cnt[p] == kk:
            t[p] = 1
    return t


@njit(cache=True, nogil=True)
def inc_insert(
    vecs,
    norms,
    seqs,
    nn_idx,
    nn_d,
    nn_key,
    nn_cnt,
    lrd,
    lof,
    mark,
    centres,
    slot,
    vec,
    seq,
    k,
    excl,
):
    """:func:`ext_insert` with lists of exactly ``k = nn_idx.shape[1]`` (no extra candidates)."""
    trunc = _trunc_of_full(nn_cnt, nn_idx.shape[1])
    return ext_insert(
        vecs,
        norms,
        seqs,
        nn_idx,
        nn_d,
        nn_key,
        nn_cnt,
        trunc,
        lrd,
        lof,
        mark,
        centres,
        slot,
        vec,
        seq,
        k,
        excl,
    )


@njit(cache=True, nogil=True)
def inc_delete(
    vecs, norms, seqs, nn_idx, nn_d, nn_key, nn_cnt, lrd, lof, mark, centres, slot, k, excl
):
    """:func:`ext_delete` with lists of exactly ``k = nn_idx.shape[1]`` (no extra candidates)."""
    trunc = _trunc_of_full(nn_cnt, nn_idx.shape[1])
    return ext_delete(
        vecs,
        norms,
        seqs,
        nn_idx,
        nn_d,
        nn_key,
        nn_cnt,
        trunc,
        lrd,
        lof,
        mark,
        centres,
        slot,
        k,
        excl,
    )
