"""Dynamic Time Alignment Kernel (Zhou et al. 2008, eq. 6-7) on a precomputed frame kernel.

Private: arrays and scalars in and out, no validation (see ``streamseg.offline.dtak``).
Every segment is a half-open frame range ``[a0, a1)`` of the frame-kernel matrix ``K``.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def dtak_table(K, a0, a1, b0, b1):
    """Full P matrix of eq. 7 between ``[a0, a1)`` (rows) and ``[b0, b1)`` (columns).

    Returns an ``(a1 - a0 + 1, b1 - b0 + 1)`` array whose row 0 and column 0 are the boundary
    (``p[0, 0] = 0``, other boundary cells ``-inf`` so every path starts at (1, 1)).
    """
    na = a1 - a0
    nb = b1 - b0
    P = np.full((na + 1, nb + 1), -np.inf)
    P[0, 0] = 0.0
    for i in range(1, na + 1):
        for j in range(1, nb + 1):
            k = K[a0 + i - 1, b0 + j - 1]
            best = P[i - 1, j] + k
            d = P[i - 1, j - 1] + 2.0 * k
            if d > best:
                best = d
            s = P[i, j - 1] + k
            if s > best:
                best = s
            P[i, j] = best
    return P


@njit(cache=True, nogil=True)
def dtak_pair(K, a0, a1, b0, b1, row):
    """DTAK value ``p[na, nb] / (na + nb)`` using one row buffer ``row`` (len >= nb + 1)."""
    na = a1 - a0
    nb = b1 - b0
    # row holds P[i - 1, :] while row i is computed in place (diag kept in a scalar).
    row[0] = 0.0
    for j in range(1, nb + 1):
        row[j] = -np.inf
    for i in range(1, na + 1):
        diag = row[0]
        row[0] = -np.inf
        left = -np.inf
        for j in range(1, nb + 1):
            k = K[a0 + i - 1, b0 + j - 1]
            up = row[j]
            best = up + k
            d = diag + 2.0 * k
            if d > best:
                best = d
            s = left + k
            if s > best:
                best = s
            diag = up
            row[j] = best
            left = best
    return row[nb] / (na + nb)


@njit(cache=True, nogil=True)
def segment_kernel(K, starts, ends):
    """Symmetric ``(m, m)`` DTAK matrix between the segments ``[starts[i], ends[i])``."""
    return segment_kernel_within(K, starts, ends, np.zeros(starts.shape[0], np.int64))


@njit(cache=True, nogil=True)
def segment_kernel_within(K, starts, ends, labels):
    """Like :func:`segment_kernel` but only for pairs of one label (other entries 0).

    ACA's cluster statistics, objective and empty-cluster re-seeding only ever read
    within-cluster entries, so this is all a descent step needs at 1/k of the cost.
    """
    m = starts.shape[0]
    T = np.zeros((m, m))
    maxlen = 0
    for i in range(m):
        if ends[i] - starts[i] > maxlen:
            maxlen = ends[i] - starts[i]
    row = np.empty(maxlen + 1)
    for i in range(m):
        for j in range(i, m):
            if labels[i] == labels[j]:
                v = dtak_pair(K, starts[i], ends[i], starts[j], ends[j], row)
                T[i, j] = v
                T[j, i] = v
    return T
