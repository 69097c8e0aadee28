"""The streaming LOF detector's state slots and its decision on a window (numba). Private.

Scalar state lives in ``st`` (int64), slots named ``ST_*``: frames seen, valid frames in the
current window, windows in the LOF buffer, next window sequence number, sequence of the last
emitted cut, NaN frames, windows dropped (too few valid frames), LOF recomputations
(statistics), last decided window sequence (each window is decided once), frame of the last
cut; with an early stage (``p[P_EARLY] > 0``) the same three decision slots for it
(``ST_E_*``) and the number of pending early cuts (``ST_PENDING``). The integer geometry
``geo`` (``GEO_*``) and float parameters ``p`` (``P_*``) are read-only.

Two stages (``p[P_EARLY] > 0``): window ``w`` is decided twice, ``P_EARLY`` windows after it
(an early, *pending* cut) and ``P_DELAY`` windows after it (the final decision, exactly the
single-stage detector's, which never reads the early stage). With ``p[P_ONSET] > 0`` the
early stage is the onset rule instead (:func:`_onset`): a pending cut as soon as the newest
window's LOF has risen ``P_ONSET_RISES`` windows in a row past ``median + P_ONSET * 1.4826 *
MAD`` of the buffered curve, before its peak is known, placed ``P_ONSET_LEAD`` windows after
the newest window's centre (where the peak window's centre is expected); ``P_EARLY`` is then
the number of windows after an onset before the next one. The final stage settles each
pending cut: a final cut of a window within ``min_gap`` windows of a pending cut's window
confirms it when the frames agree (``KIND_CONFIRM``), else withdraws it (``KIND_MOVED``) and
is emitted as a new cut; a pending cut no final cut matched by the time the final stage has
decided its window + ``min_gap`` is withdrawn (``KIND_WITHDRAW``); a final cut that matches
no pending one is a plain cut (``KIND_CUT``, final at once). So the cuts emitted minus the
withdrawn ones are the single-stage cuts at ``P_DELAY``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from streamseg._kernels.histogram import contrast_at, refine_cut, span_contrast
from streamseg._kernels.peaks import (
    curve_range,
    dominates,
    is_peak,
    is_vertex_peak,
    robust_threshold,
)

# Named slots of the state and parameter arrays (numba reads module constants at compile time)
ST_FRAMES = 0
ST_WINDOW_VALID = 1
ST_BUFFERED = 2
ST_NEXT_SEQ = 3
ST_LAST_CUT_SEQ = 4
ST_NAN_FRAMES = 5
ST_DROPPED = 6
ST_RECOMPUTES = 7
ST_LAST_DECIDED = 8
ST_LAST_CUT_FRAME = 9
ST_E_LAST_CUT_SEQ = 10
ST_E_LAST_DECIDED = 11
ST_E_LAST_CUT_FRAME = 12
ST_PENDING = 13
ST_SIZE = 14
GEO_BINS = 0
GEO_WINDOW = 1
GEO_STEP = 2
GEO_MIN_VALID = 3
GEO_K = 4
GEO_EXCLUSION = 5
GEO_REFINE = 6
GEO_CONTRAST = 7
GEO_CHECK = 8  # the first ring columns the cut's localisation, contrast and novelty read
GEO_SIZE = 9
P_DELAY = 0
P_TOLERANCE = 1
P_MADS = 2
P_MIN_SCORE = 3
P_MIN_GAP = 4
P_MIN_CONTRAST = 5
P_NOVELTY = 6
P_EARLY = 7
P_ONSET = 8  # the onset rule's threshold, MADs (0: the early stage, if any, is the peak rule)
P_ONSET_RISES = 9  # windows the newest LOF must have risen in a row
P_ONSET_LEAD = 10  # windows from the newest window's centre to where the onset places its cut
P_SIZE = 11
# event kinds (the fourth event array)
KIND_CUT = 0
KIND_PENDING = 1
KIND_CONFIRM = 2
KIND_WITHDRAW = 3
KIND_MOVED = 4

NO_CUT = -(1 << 40)


@njit(cache=True, nogil=True)
def new_state():
    st = np.zeros(ST_SIZE, dtype=np.int64)
    st[ST_LAST_CUT_SEQ] = NO_CUT
    st[ST_LAST_DECIDED] = -1
    st[ST_LAST_CUT_FRAME] = NO_CUT
    st[ST_E_LAST_CUT_SEQ] = NO_CUT
    st[ST_E_LAST_DECIDED] = -1
    st[ST_E_LAST_CUT_FRAME] = NO_CUT
    return st


@njit(cache=True, nogil=True)
def _curve(seqs, lof, st, curve):
    """Copy buffered LOF values into ``curve`` indexed by ``seq - oldest``; return oldest seq."""
    n_slots = seqs.shape[0]
    size = st[ST_BUFFERED]
    oldest = st[ST_NEXT_SEQ] - size
    first = oldest % n_slots
    n1 = min(size, n_slots - first)  # the ring's two contiguous runs, no modulo per value
    for i in range(n1):
        curve[i] = lof[first + i]
    for i in range(n1, size):
        curve[i] = lof[i - n1]
    return oldest


@njit(cache=True, nogil=True)
def _decide(w, hi, st, p, geo, frames, lofs, scratch, delay, ls, ld, lf, cache):
    """Decide window ``w`` with the curve known up to ``hi``, ``delay`` windows on each side;
    return ``(cut frame, LOF)``, the frame -1 when it is no cut. ``ls``, ``ld``, ``lf``: the
    ``st`` slots of the stage's last cut window, last decided window and last cut frame;
    ``cache`` (float64, 3): the ``ST_NEXT_SEQ`` for which ``curve`` was computed, the
    threshold ``cache[1]`` and the ``ST_NEXT_SEQ`` it was computed for (-1: none yet).

    The cut frame is the peak window's centre moved to the largest before/after histogram
    contrast within ``geo[GEO_REFINE]`` frames (:func:`refine_cut`, frames seen so far only),
    at least ``min_gap * step`` frames after the previous cut frame. With
    ``p[P_MIN_CONTRAST] > 0`` the cut is
    confirmed only when at least ``window`` frames after it have been seen and the contrast of
    the ``geo[GEO_CONTRAST]`` frames before (since the previous cut at most) and after it
    (:func:`contrast_at`) reaches ``p[P_MIN_CONTRAST]``. With ``p[P_NOVELTY] > 0`` the
    current segment must also differ from what follows: the histograms of the frames since the
    previous cut (at most the frames the ring still holds) and of the ``geo[GEO_CONTRAST]``
    frames after the cut (clipped to those seen) differ by at least ``p[P_NOVELTY]``
    (:func:`span_contrast`). ``p[P_MADS] < 0`` selects the paper's rule: no threshold
    (``min_score`` unused), and the Douglas-Peucker tolerance is ``tol`` times the range of the
    whole buffered curve instead of the local one.
    """
    rb, rv, _, left, right = frames
    # the checks read the pose columns only (LOFConfig.check_columns: not the root speeds)
    rc = rb[:, : geo[GEO_CHECK]]
    seqs, lof, centres = lofs[2], lofs[9], lofs[11]
    work, curve, keep, stack = scratch
    tol, n_mads = p[P_TOLERANCE], p[P_MADS]
    min_score, min_gap = p[P_MIN_SCORE], p[P_MIN_GAP]
    oldest = st[ST_NEXT_SEQ] - st[ST_BUFFERED]
    if w <= st[ld]:
        return -1, 0.0
    st[ld] = w
    if w < oldest or w - st[ls] < min_gap:
        return -1, 0.0
    size = st[ST_BUFFERED]
    if cache[0] != st[ST_NEXT_SEQ]:
        # the curve once per buffer state: both stages decide on it
        _curve(seqs, lof, st, curve)
        cache[0] = st[ST_NEXT_SEQ]
    yw = curve[w - oldest]
    # the checks are pure, so their order changes no decision: the cheap ones first, the
    # threshold (two selections over the buffer, most of a decision's cost) only for a
    # window that passes them (about one in ten)
    if n_mads >= 0.0 and yw < min_score:
        return -1, 0.0
    lo = max(oldest, w - delay)
    if not dominates(curve, lo - oldest, hi - oldest, w - oldest, int(min_gap)):
        return -1, 0.0
    if n_mads >= 0.0:
        peak = is_peak(curve, lo - oldest, hi - oldest, w - oldest, tol, keep, stack)
        if peak:
            if cache[2] != st[ST_NEXT_SEQ]:  # once per buffer state too
                cache[1] = robust_threshold(curve, size, n_mads, work)
                cache[2] = st[ST_NEXT_SEQ]
            if yw < cache[1]:
                return -1, 0.0
    else:
        # the paper's rule (P_MADS < 0): every peak vertex, no threshold; the tolerance is a
        # fraction of the range of the whole buffered curve, as the paper simplifies its whole
        # curve, so the wiggles of a flat stretch are not peaks
        r = curve_range(curve, 0, size - 1)
        peak = r > 0.0 and is_vertex_peak(
            curve, lo - oldest, hi - oldest, w - oldest, tol * r, keep, stack
        )
    if peak:
        c = centres[w % seqs.shape[0]]
        if geo[GEO_REFINE] > 0:
            size = rb.shape[0]
            # cut frames keep the minimum gap too (min_gap windows of step frames)
            seen = st[ST_FRAMES]
            c = refine_cut(
                rc,
                rv,
                size,
                c,
                geo[GEO_REFINE],
                geo[GEO_WINDOW],
                geo[GEO_BINS],
                seen,
                max(0, seen - size),
                st[lf] + int(min_gap) * geo[GEO_STEP],
                left,
                right,
            )
        if p[P_MIN_CONTRAST] > 0.0:
            # confirmation needs at least one window of frames after the cut (at the end of a
            # stream there may be fewer: a few frames make any histogram look different)
            if st[ST_FRAMES] - c < geo[GEO_WINDOW]:
                return -1, 0.0
            size = rb.shape[0]
            # the before side starts no earlier than the previous cut: the new segment is
            # compared with the current one, not with a change already reported
            con = contrast_at(
                rc,
                rv,
                size,
                c,
                geo[GEO_CONTRAST],
                geo[GEO_BINS],
                st[ST_FRAMES],
                max(0, st[ST_FRAMES] - size, st[lf]),
                left,
                right,
            )
            if con < p[P_MIN_CONTRAST]:
                return -1, 0.0
        if p[P_NOVELTY] > 0.0:
            # the whole current segment, not only its last contrast frames: a change that only
            # undoes a brief excursion inside the segment does not start a new one
            size = rb.shape[0]
            seen = st[ST_FRAMES]
            nov = span_contrast(
                rc,
                rv,
                size,
                max(0, seen - size, st[lf]),
                c,
                min(c + geo[GEO_CONTRAST], seen),
                geo[GEO_BINS],
                left,
                right,
            )
            if nov < p[P_NOVELTY]:
                return -1, 0.0
        st[lf] = c
        st[ls] = w
        return c, yw
    return -1, 0.0


@njit(cache=True, nogil=True)
def _emit(events, n_ev, kind, frame, score, emitted_at, window):
    ev_frame, ev_score, ev_emit, ev_kind, ev_win = events
    ev_frame[n_ev] = frame
    ev_score[n_ev] = score
    ev_emit[n_ev] = emitted_at
    ev_kind[n_ev] = kind
    ev_win[n_ev] = window
    return n_ev + 1


@njit(cache=True, nogil=True)
def _settle(w, c, y, st, p, pend, events, n_ev, emitted_at):
    """The final stage decided window ``w`` (cut frame ``c``, -1: none, LOF ``y``): settle
    the pending early cuts (``pend[:st[ST_PENDING]]`` rows: window, frame, oldest first)."""
    tol = int(p[P_MIN_GAP])
    n = st[ST_PENDING]
    if c >= 0:
        j = -1
        for i in range(n):
            if abs(pend[i, 0] - w) <= tol:
                j = i
                break
        if j < 0:
            n_ev = _emit(events, n_ev, KIND_CUT, c, y, emitted_at, w)
        else:
            fp = pend[j, 1]
            if fp == c:
                n_ev = _emit(events, n_ev, KIND_CONFIRM, c, y, emitted_at, w)
            else:
                n_ev = _emit(events, n_ev, KIND_MOVED, fp, 0.0, emitted_at, pend[j, 0])
                n_ev = _emit(events, n_ev, KIND_CUT, c, y, emitted_at, w)
            for i in range(j, n - 1):
                pend[i, 0] = pend[i + 1, 0]
                pend[i, 1] = pend[i + 1, 1]
            n -= 1
    keep = 0
    for i in range(n):
        if pend[i, 0] + tol <= w:  # no later final decision can match it
            n_ev = _emit(events, n_ev, KIND_WITHDRAW, pend[i, 1], 0.0, emitted_at, pend[i, 0])
        else:
            pend[keep, 0] = pend[i, 0]
            pend[keep, 1] = pend[i, 1]
            keep += 1
    st[ST_PENDING] = keep
    return n_ev


@njit(cache=True, nogil=True, inline="always")
def decide_stage(w, hi, st, p, geo, frames, lofs, scratch, cache, early):
    """:func:`_decide` for the final stage (``early`` 0: ``P_DELAY`` windows, the
    ``ST_LAST_*`` slots) or for the early one (``early`` windows, the ``ST_E_*`` slots)."""
    ls = ST_E_LAST_CUT_SEQ if early else ST_LAST_CUT_SEQ
    ld = ST_E_LAST_DECIDED if early else ST_LAST_DECIDED
    lf = ST_E_LAST_CUT_FRAME if early else ST_LAST_CUT_FRAME
    delay = early if early else int(p[P_DELAY])
    return _decide(w, hi, st, p, geo, frames, lofs, scratch, delay, ls, ld, lf, cache)


@njit(cache=True, nogil=True)
def _onset(seq, st, p, geo, lofs, scratch, cache):
    """The onset rule on window ``seq``, just inserted: ``(cut frame, LOF, window)`` of a
    pending cut, the frame -1 when there is none (docstring of the module). The frame is the
    newest window's centre plus ``P_ONSET_LEAD`` windows, clipped to the frames seen, at least
    ``min_gap`` windows of frames after the last cut of either stage; its window number
    (``seq + lead``) is what the final stage matches it by."""
    seqs, lof, centres = lofs[2], lofs[9], lofs[11]
    work, curve = scratch[0], scratch[1]
    rises, lead = int(p[P_ONSET_RISES]), int(p[P_ONSET_LEAD])
    oldest = st[ST_NEXT_SEQ] - st[ST_BUFFERED]
    i = seq - oldest
    if i < rises:
        return -1, 0.0, 0
    # one onset per rise: the next one at least P_EARLY windows later, and none within the
    # minimum gap of a final cut
    last = max(st[ST_E_LAST_CUT_SEQ], st[ST_LAST_CUT_SEQ])
    if seq - last < int(p[P_EARLY]) or seq + lead - st[ST_LAST_CUT_SEQ] < int(p[P_MIN_GAP]):
        return -1, 0.0, 0
    if cache[0] != st[ST_NEXT_SEQ]:
        _curve(seqs, lof, st, curve)
        cache[0] = st[ST_NEXT_SEQ]
    y = curve[i]
    if y < p[P_MIN_SCORE]:
        return -1, 0.0, 0
    for j in range(rises):
        if curve[i - j] <= curve[i - j - 1]:
            return -1, 0.0, 0
    # the threshold last (two selections over the buffer), for the few windows still rising
    if y < robust_threshold(curve, st[ST_BUFFERED], p[P_ONSET], work):
        return -1, 0.0, 0
    step = geo[GEO_STEP]
    c = centres[seq % seqs.shape[0]] + lead * step
    c = min(c, st[ST_FRAMES] - 1)
    c = max(c, st[ST_LAST_CUT_FRAME] + int(p[P_MIN_GAP]) * step)
    if c >= st[ST_FRAMES]:
        return -1, 0.0, 0
    st[ST_E_LAST_CUT_SEQ] = seq
    st[ST_E_LAST_CUT_FRAME] = c
    return c, y, seq + lead


@njit(cache=True, nogil=True)
def _step(seq, st, p, geo, frames, lofs, scratch, events, pend, n_ev, f, cache):
    """Window ``seq`` was inserted on frame ``f``: the decisions it completes."""
    w = seq - int(p[P_DELAY])
    c, y = decide_stage(w, seq, st, p, geo, frames, lofs, scratch, cache, 0)
    early = int(p[P_EARLY]) if p.shape[0] > P_EARLY else 0
    if early <= 0:
        if c >= 0:
            n_ev = _emit(events, n_ev, KIND_CUT, c, y, f, w)
        return n_ev
    n_ev = _settle(w, c, y, st, p, pend, events, n_ev, f)
    if p.shape[0] > P_ONSET and p[P_ONSET] > 0.0:
        c, y, we = _onset(seq, st, p, geo, lofs, scratch, cache)
        n = st[ST_PENDING]
        if c >= 0 and n < pend.shape[0]:
            pend[n, 0] = we
            pend[n, 1] = c
            st[ST_PENDING] = n + 1
            n_ev = _emit(events, n_ev, KIND_PENDING, c, y, f, we)
        return n_ev
    # the early stage starts from the newest cut of either stage: it adds no pending cut
    # within the minimum gap of a final one
    if st[ST_LAST_CUT_SEQ] > st[ST_E_LAST_CUT_SEQ]:
        st[ST_E_LAST_CUT_SEQ] = st[ST_LAST_CUT_SEQ]
        st[ST_E_LAST_CUT_FRAME] = st[ST_LAST_CUT_FRAME]
    we = seq - early
    c, y = decide_stage(we, seq, st, p, geo, frames, lofs, scratch, cache, early)
    if c >= 0:
        n = st[ST_PENDING]
        pend[n, 0] = we
        pend[n, 1] = c
        st[ST_PENDING] = n + 1
        n_ev = _emit(events, n_ev, KIND_PENDING, c, y, f, we)
    return n_ev
