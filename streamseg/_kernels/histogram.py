"""Per-angle histograms over sliding windows (numba). Private: arrays in, arrays out.

Frames are binned once (``bin_frames``); a window's histogram is the integer count vector of
its valid frames, laid out angle-major: entry ``a * bins + b`` counts angle ``a`` in bin ``b``.
Counts stay integers so cosine distances between windows are exact for identical windows.
"""

from __future__ import annotations

import numpy as np
from numba import njit

UNDEFINED = -2.0  # cosine distance of an empty count vector


@njit(cache=True, nogil=True)
def bin_frames(angles, bins, out_bins, out_valid):
    """Bin index of each angle (bin j holds [j pi/L, (j+1) pi/L); pi goes to the last bin).

    Parameters
    ----------
    angles : float64 (n, n_angles)
    bins : int
    out_bins : int8 (n, n_angles), written
    out_valid : uint8 (n,), written: 0 where any angle of the frame is NaN
    """
    n, a = angles.shape
    scale = bins / np.pi
    for i in range(n):
        ok = 1
        for j in range(a):
            v = angles[i, j]
            if not np.isfinite(v):
                ok = 0
                out_bins[i, j] = 0
                continue
            b = int(np.floor(v * scale))
            if b < 0:
                b = 0
            elif b >= bins:
                b = bins - 1
            out_bins[i, j] = b
        out_valid[i] = ok


@njit(cache=True, nogil=True)
def window_counts(frame_bins, valid, bins, window, step):
    """Count vectors of windows ``[w*step, w*step + window)`` by a sliding add/remove.

    Parameters
    ----------
    frame_bins : int8 (n, n_angles)
    valid : uint8 (n,)
    bins, window, step : int

    Returns
    -------
    counts : float64 (m, n_angles * bins)
        Integer counts of the valid frames of each of the ``m = (n - window) // step + 1``
        complete windows (m = 0 when n < window).
    n_valid : int64 (m,)
        Valid frames per window.
    """
    n, a = frame_bins.shape
    m = 0
    if n >= window:
        m = (n - window) // step + 1
    counts = np.zeros((m, a * bins))
    n_valid = np.zeros(m, dtype=np.int64)
    cur = np.zeros(a * bins, dtype=np.int64)
    nv = 0
    w = 0
    for f in range(n):
        if w >= m:
            break
        if valid[f]:
            nv += 1
            for j in range(a):
                cur[j * bins + frame_bins[f, j]] += 1
        old = f - window
        if old >= 0 and valid[old]:
            nv -= 1
            for j in range(a):
                cur[j * bins + frame_bins[old, j]] -= 1
        if f == w * step + window - 1:
            for d in range(a * bins):
                counts[w, d] = cur[d]
            n_valid[w] = nv
            w += 1
    return counts, n_valid


@njit(cache=True, nogil=True, inline="always")
def _add_frames(counts, ring, valid, size, lo, hi, bins):
    """Add frames ``lo .. hi - 1`` of a ring to a count vector (one modulo, not one a frame)."""
    pos = lo % size
    for _ in range(lo, hi):
        if valid[pos]:
            for a in range(ring.shape[1]):
                counts[a * bins + ring[pos, a]] += 1
        pos += 1
        if pos == size:
            pos = 0


@njit(cache=True, nogil=True, inline="always")
def _cos_distance(left, right):
    """``1 - cos`` of two count vectors (rounding may leave it just below 0); ``UNDEFINED``
    when either is all zero."""
    dot = 0.0
    nl = 0.0
    nr = 0.0
    for d in range(left.shape[0]):
        dot += float(left[d]) * float(right[d])
        nl += float(left[d]) * float(left[d])
        nr += float(right[d]) * float(right[d])
    den = np.sqrt(nl * nr)
    if den == 0.0:
        return UNDEFINED
    return 1.0 - dot / den


@njit(cache=True, nogil=True)
def refine_cut(
    ring, valid, size, centre, radius, window, bins, n_avail, oldest, first, left, right
):
    """Frame near ``centre`` where the histograms just before and just after differ most.

    Candidate ``g`` is scored by the cosine distance ``1 - cos`` between the count vectors of
    frames ``[g - window, g)`` and ``[g, g + window)`` (valid frames only); the candidates are
    ``centre - radius .. centre + radius`` restricted to those whose two sub-windows lie in
    ``[oldest, n_avail)`` and to ``g >= first`` (keeps the minimum gap to the previous cut).
    The earliest maximum wins; ``centre`` is returned when no candidate qualifies.

    The dot product and the two sums of squares are carried from one candidate to the next
    as integers (a frame moving in or out changes one count per column): O(columns) per
    candidate instead of O(columns * bins), and the same values as :func:`_cos_distance`
    summing the counts in floats, which is exact while ``columns * window**2 < 2**53``.

    Parameters
    ----------
    ring : int8 (size, n_angles)
        Bin index of frame ``g`` at row ``g % size`` (the whole recording with ``size = n``).
    valid : uint8 (size,)
        0 for frames skipped for NaN.
    size, centre, radius, window, bins : int
    n_avail : int
        Frames known (exclusive end).
    oldest : int
        Oldest frame still held in the ring.
    first : int
        Earliest allowed cut frame.
    left, right : int64 (n_angles * bins,), scratch

    Returns
    -------
    int
    """
    lo = max(centre - radius, oldest + window, first)
    hi = min(centre + radius, n_avail - window)
    if hi < lo:
        return centre
    for d in range(left.shape[0]):
        left[d] = 0
        right[d] = 0
    _add_frames(left, ring, valid, size, lo - window, lo, bins)
    _add_frames(right, ring, valid, size, lo, lo + window, bins)
    dot = 0
    nl = 0
    nr = 0
    for d in range(left.shape[0]):
        dot += left[d] * right[d]
        nl += left[d] * left[d]
        nr += right[d] * right[d]
    best = -1.0
    at = centre
    # ring rows of frames g - window (leaves the left side), g (moves from right to left)
    # and g + window (enters the right side), advanced without a modulo per frame
    p_out, p_mid, p_in = (lo - window) % size, lo % size, (lo + window) % size
    for g in range(lo, hi + 1):
        den = np.sqrt(float(nl) * float(nr))
        dist = 1.0 - float(dot) / den if den != 0.0 else 1.0  # UNDEFINED counts as 1
        if dist > best:
            best = dist
            at = g
        if g == hi:
            break
        # column by column: each column's bins are its own, so the four moves of a column
        # may be done together and the integer sums end where frame-by-frame moves end
        v_mid, v_out, v_in = valid[p_mid], valid[p_out], valid[p_in]
        for a in range(ring.shape[1]):
            base = a * bins
            if v_mid:  # frame g: into the left side, out of the right one
                i = base + ring[p_mid, a]
                c = left[i]
                nl += 2 * c + 1
                dot += right[i]
                left[i] = c + 1
            if v_out:  # frame g - window leaves the left side
                i = base + ring[p_out, a]
                c = left[i]
                nl += 1 - 2 * c
                dot -= right[i]
                left[i] = c - 1
            if v_mid:
                i = base + ring[p_mid, a]
                c = right[i]
                nr += 1 - 2 * c
                dot -= left[i]
                right[i] = c - 1
            if v_in:  # frame g + window enters the right side
                i = base + ring[p_in, a]
                c = right[i]
                nr += 2 * c + 1
                dot += left[i]
                right[i] = c + 1
        p_out = p_out + 1 if p_out + 1 < size else 0
        p_mid = p_mid + 1 if p_mid + 1 < size else 0
        p_in = p_in + 1 if p_in + 1 < size else 0
    return at


@njit(cache=True, nogil=True)
def contrast_at(ring, valid, size, g, window, bins, n_avail, oldest, left, right):
    """Cosine distance ``1 - cos`` between the count vectors of frames ``[g - window, g)`` and
    ``[g, g + window)`` (valid frames only), each clipped to the frames ``[oldest, n_avail)``.

    The two-sample statistic that confirms a cut: near 0 when both sides hold the same action,
    up to 1 when they share no bin. Returns -1.0 when a side holds no valid frame.

    Parameters
    ----------
    ring, valid, size, window, bins, n_avail, oldest : as :func:`refine_cut`
    g : int
        Candidate cut frame.
    left, right : int64 (n_angles * bins,), scratch
    """
    for d in range(left.shape[0]):
        left[d] = 0
        right[d] = 0
    _add_frames(left, ring, valid, size, max(oldest, g - window), min(g, n_avail), bins)
    _add_frames(right, ring, valid, size, max(oldest, g), min(g + window, n_avail), bins)
    d = _cos_distance(left, right)
    if d == UNDEFINED:
        return -1.0
    return 0.0 if d < 0.0 else d


@njit(cache=True, nogil=True)
def span_contrast(ring, valid, size, lo, g, hi, bins, left, right):
    """Cosine distance ``1 - cos`` between the count vectors of frames ``[lo, g)`` and
    ``[g, hi)`` (valid frames only): :func:`contrast_at` with sides of any length, e.g. the
    whole current segment against what follows it (the novelty check).

    Returns -1.0 when a side holds no valid frame.

    Parameters
    ----------
    ring, valid, size, bins : as :func:`refine_cut`
    lo, g, hi : int
        The two sides are ``[lo, g)`` and ``[g, hi)``; every frame in them must be held.
    left, right : int64 (n_angles * bins,), scratch
    """
    for d in range(left.shape[0]):
        left[d] = 0
        right[d] = 0
    _add_frames(left, ring, valid, size, lo, g, bins)
    _add_frames(right, ring, valid, size, g, hi, bins)
    d = _cos_distance(left, right)
    if d == UNDEFINED:
        return -1.0
    return 0.0 if d < 0.0 else d
