"""Local Outlier Factor with cosine distance: batch and incremental (numba). Private.

Semantics follow scikit-learn's ``LocalOutlierFactor``: each point has exactly
``min(k, n - 1)`` neighbours (itself excluded), ``lrd = 1 / (mean reach-dist + 1e-10)`` so held
poses (identical windows) give finite values, and ``LOF = mean(lrd(o)) / lrd(p)``. Ties in
distance are broken by age (sequence number), so the neighbour lists, and the order of every
floating-point sum, are identical in the batch and the incremental kernels.

Incremental updates follow Pokrajac, Lazarevic, Latecki (2007): after inserting or deleting a
point only the points whose k-neighbour list changed (set A), whose lrd depends on a changed
k-distance (B = A + points with a neighbour in A) and whose LOF depends on a changed lrd
(C = B + points with a neighbour in B) are recomputed.
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
# State (one set per stream), capacity N slots, neighbour lists of length k:
#   centres int64 (N,) time of each point (frames), for the exclusion zone;
#   vecs uint16 (N, d) integer counts; norms float64 (N,); seqs int64 (N,) (-1 = empty slot);
#   nn_idx int64 (N, k) slots; nn_d float64 (N, k); nn_key int64 (N, k) neighbour seqs;
#   nn_cnt int64 (N,); lrd, lof float64 (N,); mark int64 (N,) scratch.


@njit(cache=True, nogil=True)
def _kdist(nn_d, nn_cnt, o):
    c = nn_cnt[o]
    if c == 0:
        return 0.0
    return nn_d[o, c - 1]


@njit(cache=True, nogil=True)
def _update_lrd_lof(seqs, nn_idx, nn_d, nn_cnt, lrd, lof, mark):
    """Recompute lrd for B and LOF for C, given ``mark[p] == 1`` for the changed set A.

    Marks: 1 = A (neighbour list / k-distance changed), 2 = B, 3 = C.
    """
    n_slots = seqs.shape[0]
    # B: A plus every point with a neighbour in A (its reach-distances changed).
    for p in range(n_slots):
        if seqs[p] < 0 or mark[p] != 0:
            continue
        for t in range(nn_cnt[p]):
            if mark[nn_idx[p, t]] == 1:
                mark[p] = 2
                break
    for p in range(n_slots):
        if seqs[p] < 0 or mark[p] == 0:
            continue
        cnt = nn_cnt[p]
        if cnt == 0:
            lrd[p] = 1.0 / LRD_EPS
            continue
        s = 0.0
        for t in range(cnt):
            o = nn_idx[p, t]
            r = nn_d[p, t]
            ko = _kdist(nn_d, nn_cnt, o)
            if ko > r:
                r = ko
            s += r
        lrd[p] = 1.0 / (s / cnt + LRD_EPS)
    # C: B plus every point with a neighbour in B (its lrd ratios changed).
    for p in range(n_slots):
        if seqs[p] < 0 or mark[p] != 0:
            continue
        for t in range(nn_cnt[p]):
            m = mark[nn_idx[p, t]]
            if m == 1 or m == 2:
                mark[p] = 3
                break
    n_updated = 0
    for p in range(n_slots):
        if seqs[p] < 0 or mark[p] == 0:
            mark[p] = 0
            continue
        mark[p] = 0
        n_updated += 1
        cnt = nn_cnt[p]
        if cnt == 0:
            lof[p] = 1.0
            continue
        s = 0.0
        for t in range(cnt):
            s += lrd[nn_idx[p, t]] / lrd[p]
        lof[p] = s / cnt
    return n_updated


@njit(cache=True, nogil=True)
def inc_insert(vecs, norms, seqs, nn_idx, nn_d, nn_key, nn_cnt, lrd, lof, mark, centres,
               slot, vec, seq, k, excl):
    """Insert ``vec`` with sequence number ``seq`` into the empty ``slot``; update LOF.

    ``centres[slot]`` must hold the new point's time; points closer than ``excl`` in time are
    not neighbours.

    Returns the number of points whose LOF was recomputed.
    """
    n_slots = seqs.shape[0]
    s = 0.0
    for d in range(vec.shape[0]):
        vecs[slot, d] = vec[d]
        s += float(vecs[slot, d]) * float(vecs[slot, d])
    norms[slot] = s
    seqs[slot] = seq
    nn_cnt[slot] = 0
    mark[slot] = 1
    for j in range(n_slots):
        if j == slot or seqs[j] < 0 or abs(centres[slot] - centres[j]) < excl:
            continue
        dj = _cosdist(vecs, slot, vecs, j, norms[slot], norms[j])
        # the new point's own list
        if nn_cnt[slot] < k or dj < nn_d[slot, k - 1] or (
                dj == nn_d[slot, k - 1] and seqs[j] < nn_key[slot, k - 1]):
            nn_cnt[slot] = _insert_sorted(nn_idx[slot], nn_d[slot], nn_key[slot], nn_cnt[slot],
                                          k, j, dj, seqs[j])
        # the new point is the youngest: it enters j's list only if strictly closer
        if nn_cnt[j] < k or dj < nn_d[j, k - 1]:
            nn_cnt[j] = _insert_sorted(nn_idx[j], nn_d[j], nn_key[j], nn_cnt[j], k, slot, dj, seq)
            mark[j] = 1
    return _update_lrd_lof(seqs, nn_idx, nn_d, nn_cnt, lrd, lof, mark)


@njit(cache=True, nogil=True)
def inc_delete(vecs, norms, seqs, nn_idx, nn_d, nn_key, nn_cnt, lrd, lof, mark, centres,
               slot, k, excl):
    """Remove the point in ``slot``; rebuild the lists that held it; update LOF.

    Returns the number of points whose LOF was recomputed.
    """
    n_slots = seqs.shape[0]
    seqs[slot] = -1
    nn_cnt[slot] = 0
    lof[slot] = 0.0
    lrd[slot] = 0.0
    for p in range(n_slots):
        if seqs[p] < 0:
            continue
        for t in range(nn_cnt[p]):
            if nn_idx[p, t] == slot:
                mark[p] = 1
                break
    for p in range(n_slots):
        if mark[p] != 1:
            continue
        cnt = 0
        for j in range(n_slots):
            if j == p or seqs[j] < 0 or abs(centres[p] - centres[j]) < excl:
                continue
            dj = _cosdist(vecs, p, vecs, j, norms[p], norms[j])
            if cnt < k or dj < nn_d[p, k - 1] or (
                    dj == nn_d[p, k - 1] and seqs[j] < nn_key[p, k - 1]):
                cnt = _insert_sorted(nn_idx[p], nn_d[p], nn_key[p], cnt, k, j, dj, seqs[j])
        nn_cnt[p] = cnt
    return _update_lrd_lof(seqs, nn_idx, nn_d, nn_cnt, lrd, lof, mark)
