"""Angular-speed columns for the LOF histograms, streamed (numba). Private: arrays in, arrays out.

Frame ``t``'s speed of angle ``a`` is ``|x[t, a] - x[r, a]|`` over the nominal lag, mapped to
[0, pi] by ``pi * min(change / (speed_max * lag_s), 1)``; ``r`` is the most recent finite frame
at least ``lag`` frames before ``t`` or, before there is one, the stream's first finite frame.
A frame with any non-finite value gets NaN speeds (it is skipped anyway). State carried between
blocks: ``st`` (int64: frames seen, has reference, has first frame), ``ring`` (lag, d) of the
last ``lag`` frames, ``ref`` and ``first`` (d,).
"""

from __future__ import annotations

import numpy as np
from numba import njit

ST_FRAMES = 0
ST_HAS_REF = 1
ST_HAS_FIRST = 2
ST_SIZE = 3


@njit(cache=True, nogil=True)
def append_speeds(x, out, st, ring, ref, first, scale):
    """Write ``x`` (n, d) and its speed columns into ``out`` (n, 2 d).

    Parameters
    ----------
    x : float64 (n, d), radians
    out : float64 (n, 2 d), written: ``out[:, :d] = x``, ``out[:, d:]`` the speeds in [0, pi]
    st : int64 (ST_SIZE,), ring : float64 (lag, d), ref, first : float64 (d,); updated
    scale : float
        ``pi / (speed_max * lag_s)``: radians of change over the lag to output radians.
    """
    n, d = x.shape
    lag = ring.shape[0]
    for i in range(n):
        f = st[ST_FRAMES]
        pos = f % lag
        if f >= lag:  # frame f - lag becomes a candidate reference as it leaves the ring
            ok = True
            for a in range(d):
                if not np.isfinite(ring[pos, a]):
                    ok = False
            if ok:
                for a in range(d):
                    ref[a] = ring[pos, a]
                st[ST_HAS_REF] = 1
        ok = True
        for a in range(d):
            v = x[i, a]
            ring[pos, a] = v
            out[i, a] = v
            if not np.isfinite(v):
                ok = False
        if not ok:
            for a in range(d):
                out[i, d + a] = np.nan
        else:
            if st[ST_HAS_REF] == 0 and st[ST_HAS_FIRST] == 0:
                for a in range(d):
                    first[a] = x[i, a]
                st[ST_HAS_FIRST] = 1
            for a in range(d):
                r = ref[a] if st[ST_HAS_REF] else first[a]
                s = abs(x[i, a] - r) * scale
                out[i, d + a] = s if s < np.pi else np.pi
        st[ST_FRAMES] = f + 1
