"""The normalized affinity of ACA's spectral initialization (Zhou et al. 2008, section 4.2)
in two passes over the (m, m) matrix where numpy needed five.

Private: arrays in and out, no validation (see ``streamseg.offline.aca_init``). At m ~ 5,000
(HACA's units on the paper's synthetic take) every pass moves 25-200 MB, and numpy's
``M += M.T`` reads the transpose column by column: these kernels work in square tiles.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: tile side: two (TILE, TILE) float64 tiles stay in a 64 kB L1/L2 working set
TILE = 64


@njit(cache=True, nogil=True)
def symmetrized(A, out):
    """``out = (A + A.T) / 2`` with a zero diagonal, in ``out``'s dtype.

    Each entry is computed as numpy computes ``M = A.astype(dtype); M += M.T; M *= 0.5``:
    both values cast to ``out``'s dtype first, added and halved in it (halving is exact),
    so the result is the same to the bit. ``A`` (m, m): float64 or uint8 (a boolean matrix
    viewed as bytes); ``out`` (m, m): float32 or float64.
    """
    m = A.shape[0]
    T = out.dtype.type
    half = T(0.5)
    for i0 in range(0, m, TILE):
        i1 = min(i0 + TILE, m)
        for j0 in range(i0, m, TILE):
            j1 = min(j0 + TILE, m)
            for i in range(i0, i1):
                for j in range(max(j0, i + 1), j1):
                    v = T(T(A[i, j]) + T(A[j, i])) * half
                    out[i, j] = v
                    out[j, i] = v
            if i0 == j0:
                for i in range(i0, i1):
                    out[i, i] = 0
    return out


@njit(cache=True, nogil=True)
def scale_both(M, s):
    """``M[i, j] = (M[i, j] * s[i]) * s[j]`` in place, each product rounded to M's dtype,
    as numpy's ``M *= s[:, None]; M *= s[None, :]`` (``s`` of M's dtype)."""
    m = M.shape[0]
    for i in range(m):
        si = s[i]
        row = M[i]
        for j in range(m):
            row[j] = (row[j] * si) * s[j]


@njit(cache=True, nogil=True)
def scaled_symmetric(A, s, out):
    """``out[i, j] = (A[i, j] * s[i]) * s[j]`` off the diagonal, 0 on it, each product
    rounded to ``out``'s dtype: for a symmetric 0/1 ``A`` (uint8 or int8) the same to the bit as
    :func:`symmetrized` then :func:`scale_both`, in one pass reading rows only."""
    m = A.shape[0]
    T = out.dtype.type
    for i in range(m):
        si = s[i]
        row = out[i]
        arow = A[i]
        for j in range(m):
            row[j] = (T(arow[j]) * si) * s[j]
        row[i] = 0
    return out


@njit(cache=True, nogil=True)
def _buckets(key, n_keys, lo):
    """Frames ``i >= lo`` grouped by ``key[i]`` in ``0..n_keys-1``: ``(first, members)``,
    the frames of key ``g`` being ``members[first[g]:first[g + 1]]`` in increasing order."""
    n = key.shape[0]
    first = np.zeros(n_keys + 1, np.int64)
    for i in range(lo, n):
        first[key[i] + 1] += 1
    for g in range(n_keys):
        first[g + 1] += first[g]
    members = np.empty(n - lo, np.int64)
    fill = first[:-1].copy()
    for i in range(lo, n):
        members[fill[key[i]]] = i
        fill[key[i]] += 1
    return first, members


@njit(cache=True, nogil=True)
def propagated(classes, wmax, out):
    """Eq. 10's propagated similarity of frame ``classes`` (n,) int64 in ``0..C-1`` into the
    boolean ``out`` (n, n), which must come in all False; returns it.

    The same entries as numpy's loop over the lag ``d`` (``tests/naive.py``,
    ``naive_propagated_similarity``). The pairs ``(i1, i2)`` that lag ``d`` links are those
    with equal ``(classes[i], classes[i - d])``: grouped by that key, only the linked pairs
    are visited. Every pair is visited in both orders, so the entries set are already
    symmetric (the closure ``out |= out.T`` adds nothing).
    """
    n = classes.shape[0]
    n_classes = 0
    for i in range(n):
        if classes[i] + 1 > n_classes:
            n_classes = classes[i] + 1
    first, members = _buckets(classes, n_classes, 0)
    for g in range(n_classes):
        for a in range(first[g], first[g + 1]):
            for b in range(first[g], first[g + 1]):
                out[members[a], members[b]] = True
    key = np.empty(n, np.int64)
    for d in range(1, min(wmax, n - 1) + 1):
        for i in range(d, n):
            key[i] = classes[i] * n_classes + classes[i - d]
        first, members = _buckets(key, n_classes * n_classes, d)
        for g in range(n_classes * n_classes):
            for a in range(first[g], first[g + 1]):
                i1 = members[a]
                for b in range(first[g], first[g + 1]):
                    i2 = members[b]
                    out[i1, i2 - d] = True
                    out[i1 - d, i2] = True
    return out
