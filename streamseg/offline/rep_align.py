"""Repetition boundaries by DTW alignment against a template repetition.

Wang et al. (2015) find the boundaries from one spectral period: the velocity minima of
parameters band-passed around the primary frequency, gaps filled by that period's rhythm. When
repetitions differ in length (a pause at the rest pose before one hop, a slower kick) the
period fits none of them well. Here the repetitions found that way only give a *template*:
the one most similar to the others (their medoid under DTW). The stretch they cover is then
cut anew into consecutive pieces, each aligned by dynamic time warping to the template, the
cut of least total alignment cost winning (every piece between ``1 / stretch`` and
``stretch`` times the median repetition length). A pause stretches the template's rest
frames instead of shifting every later boundary, and the count is the number of pieces.
"""

from __future__ import annotations

import math

import numpy as np

from streamseg._kernels.rep_align import best_tiling, open_end_costs
from streamseg.exceptions import ParameterError

__all__ = ["align_repetitions", "dtw_cost"]


def _sq_dist(A, B):
    d = (A * A).sum(1)[:, None] + (B * B).sum(1)[None, :] - 2.0 * A @ B.T
    return np.ascontiguousarray(np.maximum(d, 0.0))


def dtw_cost(A, B, max_slope=2, max_compress=2) -> float:
    """Weighted mean squared frame distance along the best slope-constrained DTW path.

    Parameters
    ----------
    A : ndarray, shape (L, d)
        The template.
    B : ndarray, shape (m, d)
    max_slope : int
        Most frames of ``B`` per frame of ``A`` in one step.
    max_compress : int
        Most frames of ``A`` per frame of ``B`` in one step
        (:func:`streamseg._kernels.rep_align.open_end_costs`).

    Returns
    -------
    float
        ``D[L, m] / (L + m)``; inf when ``m`` is outside ``[L / max_compress, max_slope * L]``
        (no path).
    """
    A = np.ascontiguousarray(A, dtype=np.float64)
    B = np.ascontiguousarray(B, dtype=np.float64)
    if A.ndim != 2 or B.ndim != 2 or A.shape[1] != B.shape[1] or not len(A) or not len(B):
        raise ParameterError(f"A and B must be non-empty (frames, d) arrays of the same d; got "
                             f"shapes {A.shape} and {B.shape}")
    m = B.shape[0]
    return float(open_end_costs(_sq_dist(A, B), m, m, int(max_slope), int(max_compress))[0, m])


def _medoid(F, pieces, max_slope, max_compress):
    """Index of the piece of least summed DTW cost (as the template) to the others."""
    k = len(pieces)
    D = np.zeros((k, k))
    for i in range(k):
        for j in range(k):
            if i != j:
                D[i, j] = dtw_cost(F[pieces[i][0]:pieces[i][1]], F[pieces[j][0]:pieces[j][1]],
                                   max_slope, max_compress)
    finite = D[np.isfinite(D)]
    D[~np.isfinite(D)] = 2.0 * (finite.max() if finite.size else 1.0)  # no path: far
    return int(np.argmin(D.sum(axis=1)))


def align_repetitions(F, repetitions, fps, *, rate_hz=30.0, stretch=2.0, iterations=2,
                      max_slope=2, max_compress=2, return_template=False):
    """Re-cut the stretch covered by ``repetitions`` into pieces aligned to a template.

    Parameters
    ----------
    F : ndarray, shape (n_frames, d)
        Features per frame (e.g. the selected parameters, low-passed).
    repetitions : sequence of (int, int)
        The first estimate, 0-based, end exclusive, in time order.
    fps : float
        Frame rate of ``F``.
    rate_hz : float
        The alignment runs on ``F`` subsampled to about this rate (its cost grows with the
        cube of the frames per repetition); cuts are mapped back to full-rate frames.
    stretch : float (> 1)
        Each piece is between ``median / stretch`` and ``median * stretch`` long, ``median``
        the median length of the current pieces.
    iterations : int
        Template, re-cut, new template from the new pieces, ... this many times.
    max_slope : int
        Most sequence frames per template frame in one DTW step (:func:`dtw_cost`).
    max_compress : int
        Most template frames per sequence frame in one DTW step: a piece may be as short as
        ``1 / max_compress`` of the template (a repetition with a shorter rest than the
        template's).
    return_template : bool
        Also return the template that cut the pieces returned (for diagnoses).

    Returns
    -------
    list of (int, int)
        Consecutive pieces tiling ``[repetitions[0][0], repetitions[-1][1])``; the input
        unchanged when it holds fewer than two repetitions or no tiling fits the bounds.
    template : (int, int) or None
        With ``return_template``: its (start, end) in full-rate frames (None when nothing
        was cut).
    """
    reps = [(int(a), int(b)) for a, b in repetitions]
    if (not (stretch > 1) or iterations < 1 or max_slope < 1 or max_compress < 1
            or not rate_hz > 0 or not fps > 0):
        raise ParameterError(f"stretch={stretch!r} must be > 1, iterations={iterations!r}, "
                             f"max_slope={max_slope!r} and max_compress={max_compress!r} >= 1, "
                             f"rate_hz={rate_hz!r} and fps={fps!r} > 0")
    if len(reps) < 2:
        return (reps, None) if return_template else reps
    q = max(1, int(round(fps / rate_hz)))
    s0, s1 = reps[0][0], reps[-1][1]
    Fd = np.ascontiguousarray(np.asarray(F, dtype=np.float64)[s0:s1:q])
    n = Fd.shape[0]
    pieces = [(int(round((a - s0) / q)), int(round((b - s0) / q))) for a, b in reps]
    pieces = [(a, min(b, n)) for a, b in pieces if min(b, n) - a >= 2]
    if len(pieces) < 2:
        return (reps, None) if return_template else reps
    used = None
    for _ in range(iterations):
        a, b = pieces[_medoid(Fd, pieces, max_slope, max_compress)]
        med = float(np.median([y - x for x, y in pieces]))
        lo = max(2, int(math.floor(med / stretch)))
        hi = max(lo, int(math.ceil(med * stretch)))
        C = open_end_costs(_sq_dist(Fd[a:b], Fd), lo, hi, int(max_slope), int(max_compress))
        cuts = best_tiling(C, n, lo, hi)
        if cuts.size < 2:
            break
        used = (s0 + q * a, s0 + q * b)
        new = list(zip(cuts[:-1].tolist(), cuts[1:].tolist()))
        if new == pieces:
            break
        pieces = new
    cut = [s0 + q * x for x, _ in pieces] + [s1]
    out = [(int(x), int(y)) for x, y in zip(cut[:-1], cut[1:])]
    return (out, used) if return_template else out
