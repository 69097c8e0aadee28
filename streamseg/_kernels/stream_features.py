"""A live stream's packet in one call: positions to the cut detector's columns, learned
(numba). Private: arrays in, arrays out.

:func:`push_block` chains the kernels a packet goes through, with no Python between them:
the bone angles and inclinations (:func:`streamseg._kernels.bones.angles_kernel`), the root
speeds (:func:`streamseg._kernels.root_speed.root_speeds`), the angular speeds
(:func:`streamseg._kernels.speeds.append_speeds`, in the detector's column order) and the
streaming LOF (:func:`streamseg._kernels.lof_stream.stream_block`). The values are those of
the kernels called one by one (the same functions on the same arrays).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from streamseg._kernels.bones import angles_kernel
from streamseg._kernels.lof_stream import stream_block
from streamseg._kernels.root_speed import root_speeds
from streamseg._kernels.speeds import append_speeds


@njit(cache=True, nogil=True, error_model="numpy")
def lof_columns(pos, bones, root, speeds):
    """The detector's columns of positions ``pos`` (n, J, 3), advancing the root-speed and
    speed states.

    Parameters
    ----------
    pos : float64 (n, J, 3), C-contiguous
    bones : tuple ``(parent, child, first, second, up)``, the arguments of
        :func:`angles_kernel` (``m = len(first)`` features)
    root : tuple ``(joint, limbs, up, st, ring, prev, jump, rate, v_max)``, the arguments of
        :func:`root_speeds`; ``limbs`` with no row: no root-speed columns
    speeds : tuple ``(st, ring, ref, first, scale, order)``, the arguments of
        :func:`append_speeds` and the column order of the result (an index into its
        columns); ``ring`` with no row: no speed columns

    Returns
    -------
    angles : float64 (n, m)
        The features (the relabels' rows).
    cols : float64 (n, c)
        What the detector histograms: ``angles``, the two root speeds when ``root`` has
        limbs, then every column's speed when ``speeds`` has a ring, in ``order``.
    ok : bool (n,)
        Frames whose features are all finite.
    """
    parent, child, first, second, up = bones
    joint, limbs, rup, rst, rring, rprev, jump, rate, v_max = root
    sst, sring, sref, sfirst, scale, order = speeds
    angles = angles_kernel(pos, parent, child, first, second, up)
    n, m = angles.shape
    ok = np.ones(n, dtype=np.bool_)
    for t in range(n):
        for a in range(m):
            if not np.isfinite(angles[t, a]):
                ok[t] = False
    r = 2 if limbs.shape[0] > 0 else 0
    x = angles
    if r:
        x = np.empty((n, m + r))
        rs = np.empty((n, 2))
        root_speeds(pos, joint, limbs, rup, rst, rring, rprev, jump, rate, v_max, rs)
        for t in range(n):
            for a in range(m):
                x[t, a] = angles[t, a]
            x[t, m] = rs[t, 0]
            x[t, m + 1] = rs[t, 1]
    if sring.shape[0] == 0:
        return angles, x, ok
    d = x.shape[1]
    both = np.empty((n, 2 * d))
    append_speeds(x, both, sst, sring, sref, sfirst, scale)
    cols = np.empty((n, 2 * d))
    for t in range(n):
        for c in range(2 * d):
            cols[t, c] = both[t, order[c]]
    return angles, cols, ok


@njit(cache=True, nogil=True, error_model="numpy")
def push_block(
    pos,
    parent,
    child,
    first,
    second,
    up,
    joint,
    limbs,
    rup,
    rst,
    rring,
    rprev,
    jump,
    rate,
    v_max,
    sst,
    sring,
    sref,
    sfirst,
    scale,
    order,
    st,
    geo,
    p,
    rb,
    rv,
    cur,
    left,
    right,
    vecs,
    norms,
    seqs,
    nn_idx,
    nn_d,
    nn_key,
    nn_cnt,
    trunc,
    lrd,
    lof,
    mark,
    centres,
    rev,
    rev_cnt,
    queue,
    gate,
    work,
    curve,
    keep,
    stack,
    ev_frame,
    ev_score,
    ev_emit,
    ev_kind,
    ev_win,
    pend,
):
    """:func:`lof_columns` of ``pos``, then :func:`stream_block` on them; returns
    ``(angles, ok, n_events)``.

    The arguments are those of both, their tuples spelled out: a call then costs the
    dispatcher a few microseconds (it types each array in C) instead of some twelve (a tuple
    of arrays is typed in Python), which matters with packets of a few frames.
    """
    angles, cols, ok = lof_columns(
        pos,
        (parent, child, first, second, up),
        (joint, limbs, rup, rst, rring, rprev, jump, rate, v_max),
        (sst, sring, sref, sfirst, scale, order),
    )
    n_ev = stream_block(
        cols,
        st,
        geo,
        p,
        (rb, rv, cur, left, right),
        (
            vecs,
            norms,
            seqs,
            nn_idx,
            nn_d,
            nn_key,
            nn_cnt,
            trunc,
            lrd,
            lof,
            mark,
            centres,
            rev,
            rev_cnt,
            queue,
            gate,
        ),
        (work, curve, keep, stack),
        (ev_frame, ev_score, ev_emit, ev_kind, ev_win),
        pend,
    )
    return angles, ok, n_ev
