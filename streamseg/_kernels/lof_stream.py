"""Streaming LOF cut detector: one block of angle frames in, cut events out (numba). Private.

:func:`stream_block` keeps the sliding window histogram of the frames, inserts each
completed window into the LOF buffer (:mod:`streamseg._kernels.lof_buffer`, evicting the
oldest when it is full) and decides the windows it completes
(:mod:`streamseg._kernels.lof_decide`, which also names the slots of the state ``st``, the
geometry ``geo`` and the parameters ``p``); :func:`stream_finish` decides the last ones.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from streamseg._kernels.lof_buffer import ext_evict, ext_insert
from streamseg._kernels.lof_decide import (
    GEO_BINS,
    GEO_EXCLUSION,
    GEO_K,
    GEO_MIN_VALID,
    GEO_STEP,
    GEO_WINDOW,
    KIND_CUT,
    KIND_WITHDRAW,
    P_DELAY,
    P_EARLY,
    ST_BUFFERED,
    ST_DROPPED,
    ST_FRAMES,
    ST_NAN_FRAMES,
    ST_NEXT_SEQ,
    ST_PENDING,
    ST_RECOMPUTES,
    ST_WINDOW_VALID,
    _emit,
    _settle,
    _step,
    decide_stage,
)


@njit(cache=True, nogil=True)
def stream_block(angles, st, geo, p, frames, lofs, scratch, events, pend):
    """Feed ``angles`` (n, n_angles) frames; return the number of events written.

    ``geo`` (int64, slots ``GEO_*``) = (bins, window, step, min_valid, k, exclusion frames,
    refine radius frames, contrast frames, check columns); ``p`` (float64, slots ``P_*``) =
    (delay, tol, n_mads, min_score, min_gap, min_contrast, novelty, early delay: 0 for one
    stage). The arrays come in groups (tuples):
    ``frames = (rb, rv, cur, left, right)``, ``lofs`` the LOF buffer (the arrays of
    :data:`streamseg._kernels.lof_buffer.FIELDS`), ``scratch = (work, curve, keep, stack)``,
    ``events = (ev_frame, ev_score, ev_emit, ev_kind, ev_window)``, ``pend`` (int64, rows
    window and frame) the pending early cuts (two stages, ``p[P_EARLY] > 0``). ``rb``/``rv``
    are a ring of
    the last ``len(rb) >= window`` frames' bins and validity (frame ``f`` at ``f % len(rb)``),
    ``cur`` the current window's counts, ``left``/``right`` scratch counts. The LOF state
    is described in :mod:`streamseg._kernels.lof_buffer`; its candidate
    lists may hold more than ``k`` entries. Events: cut frame, score (LOF), frame index at
    emission, kind (``KIND_*``), the decided window's sequence number.
    """
    rb, rv, cur, left, right = frames
    vecs, seqs, centres = lofs[0], lofs[2], lofs[11]
    bins, window, step = geo[GEO_BINS], geo[GEO_WINDOW], geo[GEO_STEP]
    min_valid, k, excl = geo[GEO_MIN_VALID], geo[GEO_K], geo[GEO_EXCLUSION]
    n_slots = seqs.shape[0]
    n_ang = angles.shape[1]
    vec = np.empty(vecs.shape[1], dtype=vecs.dtype)
    cache = np.full(3, -1.0)
    scale = bins / np.pi
    n_ev = 0
    size = rb.shape[0]
    # ring rows of the entering frame and of the one leaving the window, advanced without a
    # modulo per frame
    pos = st[ST_FRAMES] % size
    old = (st[ST_FRAMES] - window) % size
    for i in range(angles.shape[0]):
        f = st[ST_FRAMES]
        if i > 0:
            pos = pos + 1 if pos + 1 < size else 0
            old = old + 1 if old + 1 < size else 0
        if f >= window and rv[old]:
            st[ST_WINDOW_VALID] -= 1
            for a in range(n_ang):
                cur[a * bins + rb[old, a]] -= 1
        ok = 1
        for a in range(n_ang):
            if not np.isfinite(angles[i, a]):
                ok = 0
        rv[pos] = ok
        if ok:
            st[ST_WINDOW_VALID] += 1
            for a in range(n_ang):
                b = int(np.floor(angles[i, a] * scale))
                if b < 0:
                    b = 0
                elif b >= bins:
                    b = bins - 1
                rb[pos, a] = b
                cur[a * bins + b] += 1
        else:
            st[ST_NAN_FRAMES] += 1
        st[ST_FRAMES] = f + 1
        if f < window - 1 or (f - (window - 1)) % step != 0:
            continue
        if st[ST_WINDOW_VALID] < min_valid:
            st[ST_DROPPED] += 1
            continue
        if st[ST_BUFFERED] == n_slots:
            oldest = st[ST_NEXT_SEQ] - n_slots
            # lrd and LOF are brought up to date once, after the insert below (Pokrajac's
            # update is exact from the marks of both changes)
            ext_evict(lofs, oldest % n_slots, k, excl)
            st[ST_BUFFERED] -= 1
        seq = st[ST_NEXT_SEQ]
        slot = seq % n_slots
        for d in range(vec.shape[0]):
            vec[d] = cur[d]
        centres[slot] = f - window + 1 + window // 2
        st[ST_RECOMPUTES] += ext_insert(lofs, slot, vec, seq, k, excl)
        st[ST_BUFFERED] += 1
        st[ST_NEXT_SEQ] = seq + 1
        n_ev = _step(seq, st, p, geo, frames, lofs, scratch, events, pend, n_ev, f, cache)
    return n_ev


@njit(cache=True, nogil=True)
def stream_finish(st, p, geo, frames, lofs, scratch, events, pend):
    """Decide the windows still waiting for their delay, with the curve as it ends; with
    an early stage, settle every pending cut (the ones no final cut matched are withdrawn)."""
    delay = int(p[P_DELAY])
    early = int(p[P_EARLY]) if p.shape[0] > P_EARLY else 0
    last = st[ST_NEXT_SEQ] - 1
    at = st[ST_FRAMES] - 1
    n_ev = 0
    cache = np.full(3, -1.0)
    for w in range(max(st[ST_NEXT_SEQ] - st[ST_BUFFERED], last - delay + 1), last + 1):
        c, y = decide_stage(w, last, st, p, geo, frames, lofs, scratch, cache, 0)
        if early > 0:
            n_ev = _settle(w, c, y, st, p, pend, events, n_ev, at)
        elif c >= 0:
            n_ev = _emit(events, n_ev, KIND_CUT, c, y, at, w)
    if early > 0:
        for i in range(st[ST_PENDING]):
            n_ev = _emit(events, n_ev, KIND_WITHDRAW, pend[i, 1], 0.0, at, pend[i, 0])
        st[ST_PENDING] = 0
    return n_ev
