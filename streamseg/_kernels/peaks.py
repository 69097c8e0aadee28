"""Peaks of a LOF curve: Douglas-Peucker simplification + robust threshold (numba). Private."""

from __future__ import annotations

import numpy as np
from numba import njit

MAD_TO_SIGMA = 1.4826  # MAD of a normal sample times this estimates its standard deviation


@njit(cache=True, nogil=True)
def dp_keep(y, lo, hi, eps, keep, stack):
    """Douglas-Peucker on the points ``(i, y[i])``, ``lo <= i <= hi``; vertical deviation.

    Sets ``keep[i - lo] = 1`` for the vertices of the simplified polyline: a point is kept when
    it deviates most from the chord of its span and by more than ``eps``.

    Parameters
    ----------
    y : float64 (n,)
    lo, hi : int, inclusive range
    eps : float
    keep : uint8 (>= hi - lo + 1,), written
    stack : int64 (>= 2 * (hi - lo + 1),) scratch
    """
    m = hi - lo + 1
    for i in range(m):
        keep[i] = 0
    keep[0] = 1
    keep[m - 1] = 1
    top = 0
    stack[0] = lo
    stack[1] = hi
    top = 2
    while top > 0:
        b = stack[top - 1]
        a = stack[top - 2]
        top -= 2
        if b - a < 2:
            continue
        best = -1.0
        at = -1
        slope = (y[b] - y[a]) / (b - a)
        for i in range(a + 1, b):
            dev = abs(y[i] - (y[a] + slope * (i - a)))
            if dev > best:
                best = dev
                at = i
        if best > eps:
            keep[at - lo] = 1
            stack[top] = a
            stack[top + 1] = at
            stack[top + 2] = at
            stack[top + 3] = b
            top += 4


@njit(cache=True, nogil=True)
def is_peak(y, lo, hi, c, tol, keep, stack):
    """Whether ``c`` is a peak vertex of the simplified curve ``y[lo..hi]``.

    The tolerance is ``tol`` times the range of ``y[lo..hi]``; ``c`` must be a vertex whose
    neighbouring vertices on both sides are strictly lower.
    """
    if c <= lo or c >= hi:
        return False
    r = curve_range(y, lo, hi)
    if r <= 0.0:
        return False
    return is_vertex_peak(y, lo, hi, c, tol * r, keep, stack)


@njit(cache=True, nogil=True)
def curve_range(y, lo, hi):
    """``max - min`` of ``y[lo..hi]`` (inclusive)."""
    ymin = y[lo]
    ymax = y[lo]
    for i in range(lo, hi + 1):
        if y[i] < ymin:
            ymin = y[i]
        if y[i] > ymax:
            ymax = y[i]
    return ymax - ymin


@njit(cache=True, nogil=True)
def is_vertex_peak(y, lo, hi, c, eps, keep, stack):
    """Whether ``c`` is a vertex of the Douglas-Peucker simplification of ``y[lo..hi]`` with
    the absolute tolerance ``eps`` whose neighbouring vertices on both sides are strictly
    lower (``lo < c < hi``)."""
    if c <= lo or c >= hi:
        return False
    dp_keep(y, lo, hi, eps, keep, stack)
    if keep[c - lo] == 0:
        return False
    p = c - 1
    while keep[p - lo] == 0:
        p -= 1
    q = c + 1
    while keep[q - lo] == 0:
        q += 1
    return y[p] < y[c] and y[q] < y[c]


@njit(cache=True, nogil=True)
def dominates(y, lo, hi, c, gap):
    """Whether no value of ``y`` within ``gap`` of ``c`` (inside ``lo..hi``) exceeds ``y[c]``."""
    for i in range(max(lo, c - gap), min(hi, c + gap) + 1):
        if y[i] > y[c]:
            return False
    return True


@njit(cache=True, nogil=True)
def select_kth(a, n, kth):
    """Reorder ``a[:n]`` so that ``a[kth]`` is its ``kth`` smallest value (0-based), every
    value before it ``<=`` and every value after it ``>=``; return ``a[kth]``.

    Quickselect around the median of three, each pass a branch-free partition (the LOF curve
    changes every window, so a branchy partition mispredicts): first ``< pivot`` to the left,
    then, if ``kth`` is not there, ``== pivot`` next, so runs of equal values end it at once.
    O(n) expected, no allocation. ``a[:n]`` must hold no NaN.
    """
    lo = 0
    hi = n - 1
    while lo < hi:
        x0 = a[lo]
        x1 = a[(lo + hi) // 2]
        x2 = a[hi]
        if x0 > x1:
            x0, x1 = x1, x0
        if x1 > x2:
            x1 = x2
            if x0 > x1:
                x1 = x0
        j = lo
        for i in range(lo, hi + 1):  # a[lo:j] < x1 <= a[j:i]
            v = a[i]
            a[i] = a[j]
            a[j] = v
            j += v < x1
        if kth < j:
            hi = j - 1
            continue
        e = j
        for i in range(j, hi + 1):  # a[j:e] == x1 < a[e:i]
            v = a[i]
            a[i] = a[e]
            a[e] = v
            e += v <= x1
        if kth < e:
            return x1
        lo = e
    return a[kth]


@njit(cache=True, nogil=True)
def _median(w, n):
    """Median of ``w[:n]`` (reordered), the value ``np.median`` gives on a NaN-free array."""
    hi = select_kth(w, n, n // 2)
    if n % 2 == 1:
        return hi
    lo = w[0]
    for i in range(1, n // 2):  # the lower middle is the largest value left of n // 2
        if w[i] > lo:
            lo = w[i]
    return 0.5 * (lo + hi)


@njit(cache=True, nogil=True)
def robust_threshold(values, n, n_mads, work):
    """``median + n_mads * 1.4826 * MAD`` of ``values[:n]`` (``work``: float64 scratch >= n)."""
    if n == 0:
        return np.inf
    finite = True
    for i in range(n):
        work[i] = values[i]
        if np.isnan(values[i]):
            finite = False
    if not finite:  # selection needs an order; sorting puts NaN last, as np.sort always did
        w = np.sort(work[:n])
        med = w[n // 2] if n % 2 == 1 else 0.5 * (w[n // 2 - 1] + w[n // 2])
        for i in range(n):
            work[i] = abs(values[i] - med)
        w = np.sort(work[:n])
        mad = w[n // 2] if n % 2 == 1 else 0.5 * (w[n // 2 - 1] + w[n // 2])
        return med + n_mads * MAD_TO_SIGMA * mad
    med = _median(work, n)
    for i in range(n):
        work[i] = abs(values[i] - med)
    mad = _median(work, n)
    return med + n_mads * MAD_TO_SIGMA * mad


@njit(cache=True, nogil=True)
def peak_windows(y, delay, tol, n_mads, min_score, min_gap):
    """Offline peak rule on a whole curve; the same rule the streaming detector applies.

    Window ``w`` is a cut when it is a peak vertex of the simplified curve ``y[w-delay ..
    w+delay]``, no value within ``min_gap`` windows of it is higher, it reaches
    ``max(min_score, median + n_mads * 1.4826 * MAD)`` of the whole curve, and it is at least
    ``min_gap`` windows after the previous cut (on ties the earlier cut wins).

    Returns
    -------
    int64 (n_cuts,) window indices
    """
    m = y.shape[0]
    work = np.empty(max(m, 1))
    thr = max(min_score, robust_threshold(y, m, n_mads, work))
    keep = np.zeros(2 * delay + 1, dtype=np.uint8)
    stack = np.zeros(4 * (2 * delay + 1) + 4, dtype=np.int64)
    out = np.empty(m, dtype=np.int64)
    n_out = 0
    last = -(1 << 40)
    for w in range(m):
        if y[w] < thr or w - last < min_gap:
            continue
        lo = max(0, w - delay)
        hi = min(m - 1, w + delay)
        if dominates(y, lo, hi, w, min_gap) and is_peak(y, lo, hi, w, tol, keep, stack):
            out[n_out] = w
            n_out += 1
            last = w
    return out[:n_out]
