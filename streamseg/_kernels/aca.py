"""ACA segmentation step: forward dynamic programme (Algorithm 1) with the active kernel
matrix of Algorithm 2 (Zhou et al. 2008, section 3.4).

Private: arrays and scalars in and out, no validation (see ``streamseg.offline.aca``).

For every end frame ``v`` the DTAK tables between each candidate segment ``[v - w, v)``
(``w = 1..wmax``) and every old segment are advanced by one row from the tables of the
candidates ``[v - w, v - 1)`` at ``v - 1``; that is the active matrix ``A`` of the paper,
laid out ``[old-frame column, candidate length]`` so the update for all lengths at one column
is a vector operation. One sweep costs O(n^2 wmax) time and O(n wmax) memory besides ``K``.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def _relax(v, L, S, lab, f, n_c, const_c, wmin, top, k):
    """Best last segment ending at frame ``v`` (eq. 9): length in [wmin, top], nearest centre.

    ``f[w, c]`` holds the DTAK sum of the candidate ``[v - w, v)`` with cluster ``c``'s
    segments; the distance to centre ``c`` is ``1 - 2 f / n_c + const_c`` (self-DTAK is 1).
    """
    for w in range(wmin, top + 1):
        head = v - w
        if L[head] == np.inf:
            continue
        bestd = np.inf
        bestc = -1
        for c in range(k):
            if n_c[c] == 0.0:
                continue
            dist = 1.0 - 2.0 * f[w, c] / n_c[c] + const_c[c]
            if dist < bestd:
                bestd = dist
                bestc = c
        total = L[head] + bestd
        if total < L[v]:
            L[v] = total
            S[v] = head
            lab[v] = bestc


@njit(cache=True, nogil=True)
def _backtrack(L, S, lab, n):
    """Segments ``(starts, ends, labels, cost)`` from the DP's back pointers; empty if none."""
    if L[n] == np.inf:
        e = np.zeros(0, np.int64)
        return e, e.copy(), e.copy(), np.inf
    cnt = 0
    v = n
    while v > 0:
        cnt += 1
        v = S[v]
    ns = np.empty(cnt, np.int64)
    ne = np.empty(cnt, np.int64)
    nl = np.empty(cnt, np.int64)
    v = n
    i = cnt - 1
    while v > 0:
        ns[i] = S[v]
        ne[i] = v
        nl[i] = lab[v]
        i -= 1
        v = S[v]
    return ns, ne, nl, L[n]


@njit(cache=True, nogil=True, fastmath=False)
def dp_search(K, starts, ends, labels, n_c, const_c, wmin, wmax):
    """One segmentation step of ACA given the previous segmentation.

    Parameters
    ----------
    K : (n, n) float64
        Frame kernel with unit diagonal (so every self-DTAK is 1).
    starts, ends : (m,) int64
        Previous segments ``[starts[j], ends[j])``.
    labels : (m,) int64
        Previous cluster of each segment, in ``0..k-1``.
    n_c : (k,) float64
        Number of previous segments per cluster (0 = empty cluster, never chosen).
    const_c : (k,) float64
        ``h_c / n_c**2`` of eq. 3 (sum of the cluster's segment-kernel block over n_c^2).
    wmin, wmax : int
        Admitted segment lengths, inclusive.

    Returns
    -------
    new_starts, new_ends, new_labels : (m',) int64
        Optimal segmentation under the previous cluster centres.
    cost : float
        Its objective under those centres (``inf`` if no tiling with these lengths exists).
    """
    n = K.shape[0]
    m = starts.shape[0]
    k = n_c.shape[0]
    W = wmax + 1
    offs = np.empty(m + 1, np.int64)
    offs[0] = 0
    for j in range(m):
        offs[j + 1] = offs[j] + (ends[j] - starts[j]) + 1
    C = offs[m]
    # Two rows of the active matrix: P for candidates ending at v-1 (prev) and v (cur).
    prev = np.full((C, W), -np.inf)
    cur = np.full((C, W), -np.inf)
    for j in range(m):
        prev[offs[j], 0] = 0.0
        cur[offs[j], 0] = 0.0
    f = np.zeros((W, k))
    L = np.full(n + 1, np.inf)
    L[0] = 0.0
    S = np.zeros(n + 1, np.int64)
    lab = np.zeros(n + 1, np.int64)
    for v in range(1, n + 1):
        krow = K[v - 1]
        f[:, :] = 0.0
        for j in range(m):
            off = offs[j]
            s0 = starts[j]
            lj = ends[j] - s0
            for b in range(1, lj + 1):
                kv = krow[s0 + b - 1]
                k2 = 2.0 * kv
                col = off + b
                for w in range(1, W):
                    best = prev[col, w - 1] + kv
                    d = prev[col - 1, w - 1] + k2
                    if d > best:
                        best = d
                    s = cur[col - 1, w] + kv
                    if s > best:
                        best = s
                    cur[col, w] = best
            c = labels[j]
            for w in range(1, W):
                f[w, c] += cur[off + lj, w] / (w + lj)
        top = wmax if wmax < v else v
        _relax(v, L, S, lab, f, n_c, const_c, wmin, top, k)
        tmp = prev
        prev = cur
        cur = tmp
    return _backtrack(L, S, lab, n)


@njit(cache=True, nogil=True)
def _advance(prev, cur, kv, reach, lmax, W):
    """One frame of the padded active matrix: ``cur`` from ``prev`` (any float dtype)."""
    for b in range(1, lmax + 1):
        kb = kv[b]
        rb = reach[b]
        for w in range(1, W):
            pc = prev[b, w - 1]
            pd = prev[b - 1, w - 1]
            cl = cur[b - 1, w]
            cc = cur[b, w]
            for j in range(rb):
                x = kb[j]
                best = pc[j] + x
                d = pd[j] + (x + x)
                if d > best:
                    best = d
                s = cl[j] + x
                if s > best:
                    best = s
                cc[j] = best


@njit(cache=True, nogil=True)
def _advance_int16(prev, cur, kv, reach, lmax, W):
    """:func:`_advance` for int16 arrays. numba widens int16 sums to int64, which defeats
    16-lane vectors; truncating every intermediate lets LLVM keep the arithmetic narrow."""
    T = np.int16
    for b in range(1, lmax + 1):
        kb = kv[b]
        rb = reach[b]
        for w in range(1, W):
            pc = prev[b, w - 1]
            pd = prev[b - 1, w - 1]
            cl = cur[b - 1, w]
            cc = cur[b, w]
            for j in range(rb):
                x = kb[j]
                a = pc[j]
                s = cl[j]
                if s > a:
                    a = s
                a = T(a + x)
                d = T(pd[j] + T(x + x))
                if d > a:
                    a = d
                cc[j] = a


@njit(cache=True, nogil=True)
def dp_search_padded(K, starts, ends, labels, n_c, const_c, wmin, wmax, prev, cur, kv, neg,
                     narrow):
    """Same as :func:`dp_search` (same results), with the old segments padded to the longest
    one and laid out ``[column, candidate length, segment]``: the innermost loop then runs over
    all old segments at once (long, vectorizable) instead of over the few candidate lengths.
    Cost O(n * m * lmax * wmax): use when ``m * lmax`` is close to ``n``. When the old
    segments come sorted by decreasing length, column b only visits the segments that reach
    it, so the padding costs nothing (any order gives the same result); sorted by label within
    one length, the sums over each cluster read contiguous memory.

    ``K`` may be given in the work dtype (each frame reads one row of it).
    ``prev``, ``cur`` : (lmax + 1, wmax + 1, m) and ``kv`` : (lmax + 1, m) work arrays;
    ``neg`` stands for -inf in their dtype; ``narrow`` must be True for int16 arrays.
    float64 in general. When ``K`` is 0/1 every P entry is an integer at most
    ``2 * (lmax + wmax)``, so int16 with ``neg = -16000`` is exact while
    ``lmax + wmax < 4000``: cells without a path (the boundary, and lengths longer than the
    frames seen so far) start at ``neg`` and gain at most ``2 * (lmax + wmax)``, so they stay
    negative and below every real entry (>= 0). int16 gives 4x the SIMD lanes of float64.
    """
    n = K.shape[0]
    m = starts.shape[0]
    k = n_c.shape[0]
    W = wmax + 1
    lens = ends - starts
    lmax = 0
    for j in range(m):
        if lens[j] > lmax:
            lmax = lens[j]
    prev[:, :, :] = neg
    cur[:, :, :] = neg
    for j in range(m):
        prev[0, 0, j] = 0.0
        cur[0, 0, j] = 0.0
    kv[:, :] = 0.0
    # reach[b]: segments 0..reach[b]-1 are all those with length >= b when sorted by length
    reach = np.zeros(lmax + 1, np.int64)
    for b in range(lmax + 1):
        r = m
        while r > 0 and lens[r - 1] < b:
            r -= 1
        reach[b] = r
        if r < m:
            for j in range(r):
                if lens[j] < b:
                    reach[b] = m  # not sorted: visit every segment
                    break
    f = np.zeros((W, k))
    # runs of consecutive segments with one (length, label): sums over a run are contiguous
    # (sorted by length then label, there are at most #lengths * k runs)
    run_lo = np.empty(m + 1, np.int64)
    nruns = 0
    for j in range(m):
        if j == 0 or lens[j] != lens[j - 1] or labels[j] != labels[j - 1]:
            run_lo[nruns] = j
            nruns += 1
    run_lo[nruns] = m
    L = np.full(n + 1, np.inf)
    L[0] = 0.0
    S = np.zeros(n + 1, np.int64)
    lab = np.zeros(n + 1, np.int64)
    for v in range(1, n + 1):
        krow = K[v - 1]
        for b in range(1, lmax + 1):
            kb = kv[b]
            for j in range(reach[b]):
                # unsorted input visits columns past a segment's end: keep the read in bounds
                kb[j] = krow[min(starts[j] + b - 1, n - 1)]
        if narrow:
            _advance_int16(prev, cur, kv, reach, lmax, W)
        else:
            _advance(prev, cur, kv, reach, lmax, W)
        top = wmax if wmax < v else v
        f[:, :] = 0.0
        for r in range(nruns):
            j0 = run_lo[r]
            j1 = run_lo[r + 1]
            lj = lens[j0]
            c = labels[j0]
            for w in range(wmin, top + 1):  # only admitted lengths are ever scored
                acc = 0  # int64 for int16 rows (exact, vectorizes), float64 for float rows
                row = cur[lj, w]
                for j in range(j0, j1):
                    acc += row[j]
                f[w, c] += acc / (w + lj)
        _relax(v, L, S, lab, f, n_c, const_c, wmin, top, k)
        tmp = prev
        prev = cur
        cur = tmp
    return _backtrack(L, S, lab, n)
