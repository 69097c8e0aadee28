"""Bone angles from joint positions, one pass per frame with no temporaries."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, error_model="numpy")
def angles_kernel(pos, parent, child, first, second, up):
    """Angle between bone ``first[a]`` and bone ``second[a]`` for every frame.

    Bone ``b`` points from joint ``parent[b]`` to joint ``child[b]``; index ``len(parent)``
    is the unit vector ``up`` (3,), so a pair ``(b, len(parent))`` is bone ``b``'s inclination
    from the vertical. A NaN joint or a zero-length bone gives NaN (IEEE arithmetic:
    ``error_model="numpy"``).

    Returns ``(n_frames, len(first))`` float64 radians in [0, pi].
    """
    n = pos.shape[0]
    nb = parent.shape[0]
    m = first.shape[0]
    out = np.empty((n, m))
    unit = np.empty((nb + 1, 3))
    unit[nb, 0] = up[0]
    unit[nb, 1] = up[1]
    unit[nb, 2] = up[2]
    for f in range(n):
        for b in range(nb):
            x = pos[f, child[b], 0] - pos[f, parent[b], 0]
            y = pos[f, child[b], 1] - pos[f, parent[b], 1]
            z = pos[f, child[b], 2] - pos[f, parent[b], 2]
            norm = np.sqrt(x * x + y * y + z * z)
            unit[b, 0] = x / norm
            unit[b, 1] = y / norm
            unit[b, 2] = z / norm
        for a in range(m):
            i = first[a]
            j = second[a]
            c = unit[i, 0] * unit[j, 0] + unit[i, 1] * unit[j, 1] + unit[i, 2] * unit[j, 2]
            if c > 1.0:
                c = 1.0
            elif c < -1.0:
                c = -1.0
            out[f, a] = np.arccos(c)
    return out
