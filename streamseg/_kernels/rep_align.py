"""Open-end DTW of one template repetition against every stretch of a sequence.

Private: arrays and scalars in and out, no validation (see ``streamseg.offline.rep_align``).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def open_end_costs(dist, lo, hi, max_slope, max_compress=2):
    """Mean DTW cost of a template against ``X[a:a + m]`` for every start a and length m.

    Slope-constrained steps, each weighted by the frames it advances on both axes, so
    ``D[L, m] / (L + m)`` is a weighted mean of the frame distances along the path: a
    diagonal step (1, 1) weighs its cell 2; a step (k, 1) for k = 2..``max_compress`` (k
    template frames on one sequence frame) and (1, k) for k = 2..``max_slope`` (a sequence
    frame held) visit every cell they cross. The path's slope stays within
    [1/``max_compress``, ``max_slope``]: one stretch of the sequence can never be squeezed
    onto a single template frame.

    Parameters
    ----------
    dist : ndarray, shape (L, n)
        Squared distance of template frame i to sequence frame t.
    lo, hi : int
        Shortest and longest stretch, frames (1 <= lo <= hi).
    max_slope : int
        Most sequence frames per template frame in one step (>= 1).
    max_compress : int
        Most template frames per sequence frame in one step (>= 1; 2 before issue 14's
        round 9).

    Returns
    -------
    ndarray, shape (n, hi + 1)
        ``C[a, m]``: the mean cost for ``lo <= m <= min(hi, n - a)``, ``inf`` elsewhere
        (and where no path of the allowed slopes exists).
    """
    L, n = dist.shape
    C = np.full((n, hi + 1), np.inf)
    D = np.empty((L + 1, hi + 1))
    for a in range(n):
        w = min(hi, n - a)
        if w < lo:
            continue
        D[:, :] = np.inf
        D[0, 0] = 0.0
        for i in range(1, L + 1):
            for j in range(1, w + 1):
                c = dist[i - 1, a + j - 1]
                best = D[i - 1, j - 1] + 2.0 * c
                acc = 2.0 * c
                for k in range(2, max_compress + 1):
                    if i - k < 0:
                        break
                    acc += dist[i - k, a + j - 1]
                    v = D[i - k, j - 1] + acc
                    if v < best:
                        best = v
                acc = 2.0 * c
                for k in range(2, max_slope + 1):
                    if j - k < 0:
                        break
                    acc += dist[i - 1, a + j - k]
                    v = D[i - 1, j - k] + acc
                    if v < best:
                        best = v
                D[i, j] = best
        for m in range(lo, w + 1):
            C[a, m] = D[L, m] / (L + m)
    return C


@njit(cache=True, nogil=True)
def best_tiling(C, n, lo, hi):
    """Cut ``[0, n)`` into stretches of ``lo..hi`` frames minimising the sum of ``m * C[a, m]``.

    Returns
    -------
    cuts : ndarray of int64
        ``0 = c_0 < c_1 < ... < c_K = n``; empty when no tiling exists.
    """
    best = np.full(n + 1, np.inf)
    back = np.full(n + 1, -1, dtype=np.int64)
    best[0] = 0.0
    for b in range(lo, n + 1):
        for m in range(lo, min(hi, b) + 1):
            a = b - m
            if best[a] < np.inf:
                v = best[a] + m * C[a, m]
                if v < best[b]:
                    best[b] = v
                    back[b] = a
    if back[n] < 0:
        return np.empty(0, dtype=np.int64)
    k = 0
    b = n
    while b > 0:
        b = back[b]
        k += 1
    cuts = np.empty(k + 1, dtype=np.int64)
    b = n
    for i in range(k, -1, -1):
        cuts[i] = b
        if b > 0:
            b = back[b]
    return cuts
