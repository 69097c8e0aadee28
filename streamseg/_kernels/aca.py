"""ACA segmentation step: the forward dynamic programme of Algorithm 1 (Zhou et al. 2008,
eq. 9) on the DTAKs between every candidate segment and every old segment.

Private: arrays and scalars in and out, no validation (see ``streamseg.offline.aca``).

The DTAK sums a step needs do not depend on the programme's own costs, so they are computed
first (:func:`candidate_sums`), old segment by old segment: for segment ``j`` and every
candidate start ``t`` at once, the eq. 7 table between ``j`` and the candidates
``[t, t + w)`` (``w = 1..wmax``) is filled column by column of ``j``. Its innermost loop runs
over all ``n`` starts and reads one contiguous row of the frame kernel, so it vectorizes at
full width (32 int8, 16 int16 or 4 float64 lanes) with no gather. The work is
``n * wmax * (sum of the old lengths) = O(n^2 wmax)`` whatever the old lengths are, and the
memory ``O(n wmax)`` per group of old segments besides ``K``. :func:`relax` then runs eq. 9
in ``O(n wmax k)``.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def _column(up, diag, left, out, x, cnt):
    """Eq. 7 for one cell ``(b, w)`` of the tables of every candidate start ``t < cnt``:
    ``out = max(up + x, left + x, diag + 2 x)``. A function of its own so that LLVM
    vectorizes it (inside the caller's loop nest it did not)."""
    T = out.dtype.type
    for t in range(cnt):
        xx = x[t]
        a = up[t]
        c = left[t]
        if c > a:
            a = c
        # cast back: numba widens narrow sums to int64 (4 lanes instead of 32); for floats
        # max(a, c) + x == max(a + x, c + x) exactly (rounding is monotonic)
        a = T(a + xx)
        d = T(diag[t] + T(xx + xx))
        if d > a:
            a = d
        out[t] = a


@njit(cache=True, nogil=True)
def candidate_sums(K, starts, ends, labels, counts, wmin, wmax, A, B, acc, F, neg):
    """DTAK sums of every candidate segment with every old cluster.

    Parameters
    ----------
    K : (n, n) array
        Frame kernel, read as ``K[old frame, candidate frame]`` (pass ``K.T`` if it is not
        symmetric): float64, or int8/int16 holding a 0/1 kernel.
    starts, ends, labels : (m,) int64
        Old segments ``[starts[j], ends[j])`` and their clusters, sorted by decreasing length
        then label (this fixes the order of the floating-point sums).
    counts : (m,) int64
        How many old segments of identical frames each one stands for (its table is added
        that many times; integer tables only, so the sums are exact; 1 for a float ``K``).
    wmin, wmax : int
        Candidate lengths whose sums are kept (the tables are filled from length 1).
    A, B : (wmax + 1, n + 1) work arrays
        float64 for a float K; int8 or int16 for a 0/1 kernel (see ``neg``).
    acc : (wmax + 1, n + 1) work array, float64, or int64 with integer work arrays
    F : (k, wmax + 1, n + 1) float64 zeros
        Out: ``F[c, w, t]`` = sum over the old segments j of cluster c of
        ``DTAK(j, [t, t + w))`` (eq. 6), for ``wmin <= w <= wmax`` and ``t <= n - w``; the
        numerators of one run of equal length and label are summed before the division.
    neg : scalar of the work dtype
        Stands for -inf: -inf for floats. With a 0/1 kernel every real entry is an integer
        in ``[0, len + w]`` (a warping path weighs each kernel value once per coordinate it
        advances) and a boundary cell gains at most ``len + w``, so int8 with -64 is exact
        while ``len + wmax <= 60`` and int16 with -16000 while ``len + wmax < 4000``.
    """
    n = K.shape[0]
    m = starts.shape[0]
    W = wmax + 1
    acc[:, :] = 0
    for j in range(m):
        s = starts[j]
        ln = ends[j] - s
        # column 0 of segment j: P[0, 0] = 0, P[0, w > 0] = -inf
        A[0, :] = 0
        A[1:, :] = neg
        B[0, :] = neg  # P[b > 0, 0] = -inf
        for b in range(1, ln + 1):
            krow = K[s + b - 1]
            for w in range(1, W):
                _column(A[w], A[w - 1], B[w - 1], B[w], krow[w - 1 :], n - w + 1)
            A, B = B, A
            B[0, :] = neg
        times = counts[j]
        for w in range(wmin, W):
            row = A[w]
            aw = acc[w]
            if times == 1:
                for t in range(n - w + 1):
                    aw[t] += row[t]
            else:
                for t in range(n - w + 1):
                    aw[t] += times * row[t]
        if j == m - 1 or ends[j + 1] - starts[j + 1] != ln or labels[j + 1] != labels[j]:
            fc = F[labels[j]]
            for w in range(wmin, W):
                aw = acc[w]
                fw = fc[w]
                den = w + ln
                for t in range(n - w + 1):
                    fw[t] += aw[t] / den
                    aw[t] = 0


@njit(cache=True, nogil=True)
def relax(F, n_c, const_c, wmin, wmax):
    """Eq. 9 over the candidate sums: the best segmentation under the old centres.

    ``F`` (k, wmax + 1, n + 1) from :func:`candidate_sums`; ``n_c`` (k,) segments per old
    cluster (0 = empty, never chosen), ``const_c`` (k,) its ``h_c / n_c**2`` (eq. 3). The
    distance of candidate ``[v - w, v)`` to centre ``c`` is ``1 - 2 F[c, w, v - w] / n_c +
    const_c`` (self-DTAK is 1).

    Returns
    -------
    starts, ends, labels : (m',) int64
    cost : float
        The objective under the old centres (``inf`` if no tiling with these lengths).
    """
    n = F.shape[2] - 1
    k = n_c.shape[0]
    L = np.full(n + 1, np.inf)
    L[0] = 0.0
    S = np.zeros(n + 1, np.int64)
    lab = np.zeros(n + 1, np.int64)
    for v in range(1, n + 1):
        top = wmax if wmax < v else v
        for w in range(wmin, top + 1):
            head = v - w
            if L[head] == np.inf:
                continue
            bestd = np.inf
            bestc = -1
            for c in range(k):
                if n_c[c] == 0.0:
                    continue
                dist = 1.0 - 2.0 * F[c, w, head] / n_c[c] + const_c[c]
                if dist < bestd:
                    bestd = dist
                    bestc = c
            total = L[head] + bestd
            if total < L[v]:
                L[v] = total
                S[v] = head
                lab[v] = bestc
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
