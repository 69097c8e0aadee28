"""Streaming LOF cut detector: one block of angle frames in, cut events out (numba). Private.

Scalar state lives in ``st`` (int64):
  0 frames seen, 1 valid frames in the current window, 2 windows in the LOF buffer,
  3 next window sequence number, 4 sequence of the last emitted cut, 5 NaN frames,
  6 windows dropped (too few valid frames), 7 LOF recomputations (statistics),
  8 last decided window sequence (each window is decided once), 9 frame of the last cut.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from streamseg._kernels.histogram import contrast_at, refine_cut
from streamseg._kernels.lof import ext_evict, ext_insert
from streamseg._kernels.peaks import dominates, is_peak, robust_threshold

NO_CUT = -(1 << 40)


@njit(cache=True, nogil=True)
def new_state():
    st = np.zeros(10, dtype=np.int64)
    st[4] = NO_CUT
    st[8] = -1
    st[9] = NO_CUT
    return st


@njit(cache=True, nogil=True)
def _curve(seqs, lof, st, curve):
    """Copy buffered LOF values into ``curve`` indexed by ``seq - oldest``; return oldest seq."""
    n_slots = seqs.shape[0]
    size = st[2]
    oldest = st[3] - size
    first = oldest % n_slots
    n1 = min(size, n_slots - first)  # the ring's two contiguous runs, no modulo per value
    for i in range(n1):
        curve[i] = lof[first + i]
    for i in range(n1, size):
        curve[i] = lof[i - n1]
    return oldest


@njit(cache=True, nogil=True)
def _decide(w, hi, seqs, lof, centres, st, p, geo, rb, rv, left, right, work, curve, keep, stack,
            ev_frame, ev_score, ev_emit, n_ev, emitted_at):
    """Decide window ``w`` with the curve known up to ``hi``; append an event if it is a cut.

    The cut frame is the peak window's centre moved to the largest before/after histogram
    contrast within ``geo[6]`` frames (:func:`refine_cut`, frames seen so far only), at least
    ``min_gap * step`` frames after the previous cut frame. With ``p[5] > 0`` the cut is
    confirmed only when at least ``window`` frames after it have been seen and the contrast of
    the ``geo[7]`` frames before (since the previous cut at most) and after it
    (:func:`contrast_at`) reaches ``p[5]``.
    """
    delay, tol, n_mads, min_score, min_gap = p[0], p[1], p[2], p[3], p[4]
    oldest = st[3] - st[2]
    if w <= st[8]:
        return n_ev
    st[8] = w
    if w < oldest or w - st[4] < min_gap:
        return n_ev
    oldest = _curve(seqs, lof, st, curve)
    size = st[2]
    yw = curve[w - oldest]
    thr = robust_threshold(curve, size, n_mads, work)
    if thr < min_score:
        thr = min_score
    if yw < thr:
        return n_ev
    lo = max(oldest, w - int(delay))
    if dominates(curve, lo - oldest, hi - oldest, w - oldest, int(min_gap)) and is_peak(
            curve, lo - oldest, hi - oldest, w - oldest, tol, keep, stack):
        c = centres[w % seqs.shape[0]]
        if geo[6] > 0:
            size = rb.shape[0]
            # cut frames keep the minimum gap too (min_gap windows of step frames)
            c = refine_cut(rb, rv, size, c, geo[6], geo[1], geo[0], st[0], max(0, st[0] - size),
                           st[9] + int(min_gap) * geo[2], left, right)
        if p[5] > 0.0:
            # confirmation needs at least one window of frames after the cut (at the end of a
            # stream there may be fewer: a few frames make any histogram look different)
            if st[0] - c < geo[1]:
                return n_ev
            size = rb.shape[0]
            # the before side starts no earlier than the previous cut: the new segment is
            # compared with the current one, not with a change already reported
            con = contrast_at(rb, rv, size, c, geo[7], geo[0], st[0],
                              max(0, st[0] - size, st[9]), left, right)
            if con < p[5]:
                return n_ev
        st[9] = c
        ev_frame[n_ev] = c
        ev_score[n_ev] = yw
        ev_emit[n_ev] = emitted_at
        st[4] = w
        return n_ev + 1
    return n_ev


@njit(cache=True, nogil=True)
def stream_block(angles, st, geo, p,
                 rb, rv, cur, left, right,
                 vecs, norms, seqs, nn_idx, nn_d, nn_key, nn_cnt, trunc, lrd, lof, mark,
                 centres, work, curve, keep, stack,
                 ev_frame, ev_score, ev_emit):
    """Feed ``angles`` (n, n_angles) frames; return the number of events written.

    ``geo`` = (bins, window, step, min_valid, k, exclusion frames, refine radius frames,
    contrast frames);
    ``p`` = (delay, tol, n_mads, min_score, min_gap, min_contrast) as float64;
    ``geo[7]`` is the contrast sub-window (frames). ``rb``/``rv`` are a ring of
    the last ``len(rb) >= window`` frames' bins and validity (frame ``f`` at ``f % len(rb)``),
    ``cur`` the current window's counts, ``left``/``right`` scratch counts. The LOF state
    (``vecs`` .. ``centres``) is described in :mod:`streamseg._kernels.lof`; its candidate
    lists may hold more than ``k`` entries. Events: cut frame, score (LOF), frame index at
    emission.
    """
    bins, window, step, min_valid, k, excl = geo[0], geo[1], geo[2], geo[3], geo[4], geo[5]
    n_slots = seqs.shape[0]
    n_ang = angles.shape[1]
    delay = int(p[0])
    vec = np.empty(vecs.shape[1], dtype=np.uint16)
    scale = bins / np.pi
    n_ev = 0
    size = rb.shape[0]
    for i in range(angles.shape[0]):
        f = st[0]
        pos = f % size
        old = (f - window) % size
        if f >= window and rv[old]:
            st[1] -= 1
            for a in range(n_ang):
                cur[a * bins + rb[old, a]] -= 1
        ok = 1
        for a in range(n_ang):
            if not np.isfinite(angles[i, a]):
                ok = 0
        rv[pos] = ok
        if ok:
            st[1] += 1
            for a in range(n_ang):
                b = int(np.floor(angles[i, a] * scale))
                if b < 0:
                    b = 0
                elif b >= bins:
                    b = bins - 1
                rb[pos, a] = b
                cur[a * bins + b] += 1
        else:
            st[5] += 1
        st[0] = f + 1
        if f < window - 1 or (f - (window - 1)) % step != 0:
            continue
        if st[1] < min_valid:
            st[6] += 1
            continue
        if st[2] == n_slots:
            oldest = st[3] - n_slots
            # lrd and LOF are brought up to date once, after the insert below (Pokrajac's
            # update is exact from the marks of both changes)
            ext_evict(vecs, norms, seqs, nn_idx, nn_d, nn_key, nn_cnt, trunc, lrd, lof, mark,
                      centres, oldest % n_slots, k, excl)
            st[2] -= 1
        seq = st[3]
        slot = seq % n_slots
        for d in range(vec.shape[0]):
            vec[d] = cur[d]
        centres[slot] = f - window + 1 + window // 2
        st[7] += ext_insert(vecs, norms, seqs, nn_idx, nn_d, nn_key, nn_cnt, trunc, lrd, lof,
                            mark, centres, slot, vec, seq, k, excl)
        st[2] += 1
        st[3] = seq + 1
        n_ev = _decide(seq - delay, seq, seqs, lof, centres, st, p, geo, rb, rv, left, right,
                       work, curve, keep, stack, ev_frame, ev_score, ev_emit, n_ev, f)
    return n_ev


@njit(cache=True, nogil=True)
def stream_finish(st, p, geo, rb, rv, left, right, seqs, lof, centres, work, curve, keep, stack,
                  ev_frame, ev_score, ev_emit):
    """Decide the windows still waiting for their delay, with the curve as it ends."""
    delay = int(p[0])
    last = st[3] - 1
    n_ev = 0
    for w in range(max(st[3] - st[2], last - delay + 1), last + 1):
        n_ev = _decide(w, last, seqs, lof, centres, st, p, geo, rb, rv, left, right, work, curve,
                       keep, stack, ev_frame, ev_score, ev_emit, n_ev, st[0] - 1)
    return n_ev
