"""The normalized affinity of ACA's spectral initialization (Zhou et al. 2008, section 4.2)
in two passes over the (m, m) matrix where numpy needed five.

Private: arrays in and out, no validation (see ``streamseg.offline.aca_init``). At m ~ 5,000
(HACA's units on the paper's synthetic take) every pass moves 25-200 MB, and numpy's
``M += M.T`` reads the transpose column by column: these kernels work in square tiles.
"""

from __future__ import annotations

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
