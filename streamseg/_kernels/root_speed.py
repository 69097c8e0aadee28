"""Root-speed columns (numba). Private: arrays in, arrays out; see
:mod:`streamseg.online.root_speed` for the definition."""

from __future__ import annotations

import math

from numba import njit

ST_POS = 0  # next ring row to write
ST_FRESH = 1  # 1: the next frame is a stream's first (its step is 0)
ST_SIZE = 2


@njit(cache=True, nogil=True)
def root_speeds(pos, root, limbs, up, st, ring, prev, jump, rate, v_max, out):
    """Write the two root-speed columns of each frame of ``pos``, advancing the state.

    Parameters
    ----------
    pos : float64 (n, J, 3)
        Joint positions, any length unit.
    root : int
        Joint index of the root.
    limbs : int64 (b, 2)
        End points of the bones whose mean length is the frame's body scale.
    up : float64 (3,)
        Unit up vector.
    st : int64 (ST_SIZE,)
        Ring position and the fresh flag.
    ring : float64 (lag, 3)
        The last ``lag`` steps in body scales (rows in ring order).
    prev : float64 (3,)
        The previous frame's root position.
    jump : float
        Steps longer than this (body scales per frame) count as 0; NaN steps stay NaN.
    rate : float
        ``fps / lag``: a sum of ``lag`` steps times this is a speed in body scales/s.
    v_max : float
        Speed mapped to pi.
    out : float64 (n, 2), written
        ``pi * min(speed / v_max, 1)`` of the horizontal and vertical speed; NaN while a NaN
        step is among the last ``lag``.
    """
    lag = ring.shape[0]
    nb = limbs.shape[0]
    for t in range(pos.shape[0]):
        s = 0.0
        for b in range(nb):
            d2 = 0.0
            for a in range(3):
                d = pos[t, limbs[b, 1], a] - pos[t, limbs[b, 0], a]
                d2 += d * d
            s += math.sqrt(d2)
        s /= nb
        if not s > 0.0:
            s = math.nan
        row = st[ST_POS]
        norm2 = 0.0
        for a in range(3):
            x = pos[t, root, a]
            step = 0.0 * x / s if st[ST_FRESH] else (x - prev[a]) / s
            ring[row, a] = step
            norm2 += step * step
            prev[a] = x
        if math.sqrt(norm2) > jump:  # False for NaN: a NaN step stays NaN
            for a in range(3):
                ring[row, a] = 0.0
        st[ST_POS] = (row + 1) % lag
        st[ST_FRESH] = 0
        m0 = 0.0
        m1 = 0.0
        m2 = 0.0
        for r in range(lag):
            m0 += ring[r, 0]
            m1 += ring[r, 1]
            m2 += ring[r, 2]
        vert = m0 * up[0] + m1 * up[1] + m2 * up[2]
        h0, h1, h2 = m0 - vert * up[0], m1 - vert * up[1], m2 - vert * up[2]
        hor = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2) * rate
        vert = abs(vert) * rate
        if math.isnan(hor) or math.isnan(vert):
            out[t, 0] = math.nan
            out[t, 1] = math.nan
        else:
            out[t, 0] = math.pi * min(hor / v_max, 1.0)
            out[t, 1] = math.pi * min(vert / v_max, 1.0)
