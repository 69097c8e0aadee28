"""Local Outlier Factor with cosine distance over a whole matrix (numba). Private.

Semantics follow scikit-learn's ``LocalOutlierFactor``: each point has exactly
``min(k, n - 1)`` neighbours (itself excluded), ``lrd = 1 / (mean reach-dist + 1e-10)`` so held
poses (identical windows) give finite values, and ``LOF = mean(lrd(o)) / lrd(p)``. Ties in
distance are broken by age (sequence number), so the neighbour lists, and the order of every
floating-point sum, are identical in the batch and the incremental kernels.

The incremental twin over a ring buffer is :mod:`streamseg._kernels.lof_buffer`.
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


@njit(cache=True, nogil=True, inline="always")
def kdist_of(nn_d, nn_cnt, o, k):
    """k-distance of point ``o``: the distance of its ``min(k, nn_cnt[o])``-th neighbour."""
    c = min(nn_cnt[o], k)
    if c == 0:
        return 0.0
    return nn_d[o, c - 1]


@njit(cache=True, nogil=True, inline="always")
def lrd_of(nn_idx, nn_d, nn_cnt, p, k):
    """Local reachability density of ``p`` from its first ``min(k, nn_cnt[p])`` neighbours
    (the rows of ``nn_idx``/``nn_d``, nearest first)."""
    cnt = min(nn_cnt[p], k)
    if cnt == 0:
        return 1.0 / LRD_EPS
    s = 0.0
    for t in range(cnt):
        r = nn_d[p, t]
        ko = kdist_of(nn_d, nn_cnt, nn_idx[p, t], k)
        if ko > r:
            r = ko
        s += r
    return 1.0 / (s / cnt + LRD_EPS)


@njit(cache=True, nogil=True, inline="always")
def lof_of(nn_idx, nn_cnt, lrd, p, k):
    """LOF of ``p``: the mean ratio of its neighbours' lrd to its own (1 without any)."""
    cnt = min(nn_cnt[p], k)
    if cnt == 0:
        return 1.0
    s = 0.0
    for t in range(cnt):
        s += lrd[nn_idx[p, t]] / lrd[p]
    return s / cnt


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
    lof = np.empty(n)
    for i in range(n):
        kdist[i] = kdist_of(nd, cnts, i, kk)
    for i in range(n):
        lrd[i] = lrd_of(nn, nd, cnts, i, kk)
    for i in range(n):
        lof[i] = lof_of(nn, cnts, lrd, i, kk)
    return lof, lrd, kdist, nn, cnts
