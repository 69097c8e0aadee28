"""Frame kernels and the Dynamic Time Alignment Kernel (Zhou et al. 2008, eq. 6-7).

The frame kernel is either Gaussian, ``k(x, y) = exp(-|x - y|^2 / (2 sigma^2))``, or the exact
equality kernel (the limit sigma -> 0 used by the paper's synthetic experiment: 1 when two
frames are equal, else 0). Both have a unit diagonal, which ACA relies on: the DTAK of any
segment with itself is then exactly 1.

Default bandwidth (``sigma=None``): ``sigma = SIGMA_SCALE * median_i d_i`` where ``d_i`` is the
Euclidean distance from frame i to its ``ceil(SIGMA_NEIGHBOUR_FRACTION * n)``-th nearest
other frame (at most 2,000 frames, evenly sampled, enter the estimate). A bandwidth at the
scale of local neighbourhoods keeps frames of one action similar and frames of different
actions near zero, whatever the units of the features.
"""

from __future__ import annotations

import math

import numpy as np

from streamseg._kernels.dtak import dtak_pair, dtak_table, segment_kernel
from streamseg.exceptions import ParameterError

KERNELS = ("gaussian", "equality")
SIGMA_NEIGHBOUR_FRACTION = 0.02
SIGMA_SCALE = 1.0


def _as_frames(X, name="X") -> np.ndarray:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim == 1:
        X = X[:, None]
    if X.ndim != 2 or X.shape[0] == 0:
        raise ParameterError(f"{name} must be a non-empty (n_frames, d) array, got shape {X.shape}")
    if not np.all(np.isfinite(X)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(X), axis=1))[0])
        raise ParameterError(
            f"{name} has non-finite values (first at frame {bad}); interpolate or drop those frames"
        )
    return X


def _sq_dists(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    d = (X * X).sum(1)[:, None] + (Y * Y).sum(1)[None, :] - 2.0 * X @ Y.T
    return np.maximum(d, 0.0)


def default_sigma(X) -> float:
    """Bandwidth from the data (module docstring). ``X``: (n_frames, d). Returns sigma > 0."""
    X = _as_frames(X)
    n = X.shape[0]
    if n > 2000:
        X = X[np.linspace(0, n - 1, 2000).astype(np.int64)]
        n = 2000
    if n < 2:
        return 1.0
    q = min(n - 1, max(1, math.ceil(SIGMA_NEIGHBOUR_FRACTION * n)))
    d = np.sqrt(_sq_dists(X, X))
    np.fill_diagonal(d, np.inf)
    kth = np.partition(d, q - 1, axis=1)[:, q - 1]
    sigma = SIGMA_SCALE * float(np.median(kth))
    if not sigma > 0:
        # Many identical frames: fall back to the typical spread so the kernel stays informative.
        spread = float(np.median(d[np.isfinite(d)])) if n > 1 else 0.0
        sigma = spread if spread > 0 else 1.0
    return sigma


def frame_kernel(
    X, Y=None, *, kernel: str = "gaussian", sigma: float | None = None, binary_dtype=np.float64
) -> np.ndarray:
    """Frame kernel matrix between the rows of ``X`` (n, d) and ``Y`` (n2, d; default ``X``).

    Parameters
    ----------
    kernel : {"gaussian", "equality"}
    sigma : float or None
        Gaussian bandwidth; None = :func:`default_sigma` of ``X``. Ignored for "equality".
    binary_dtype : dtype
        dtype of the 0/1 "equality" kernel (ACA uses int8: exact, 8x less memory).

    Returns
    -------
    (n, n2) array with values in [0, 1] (unit diagonal when ``Y`` is ``X``), float64 for
    "gaussian".
    """
    X = _as_frames(X)
    Y = X if Y is None else _as_frames(Y, "Y")
    if X.shape[1] != Y.shape[1]:
        raise ParameterError(f"X has {X.shape[1]} columns but Y has {Y.shape[1]}; they must match")
    if kernel == "equality":
        # Compare integer ids of distinct rows: O(n d) memory instead of an (n, n2, d) array.
        _, ids = np.unique(np.vstack([X, Y]), axis=0, return_inverse=True)
        ids = ids.ravel()
        return (ids[: X.shape[0], None] == ids[None, X.shape[0] :]).astype(binary_dtype)
    if kernel != "gaussian":
        raise ParameterError(f"kernel={kernel!r} is invalid: expected one of {KERNELS}")
    if sigma is None:
        sigma = default_sigma(X)
    if not (isinstance(sigma, (int, float)) and math.isfinite(sigma) and sigma > 0):
        raise ParameterError(f"sigma={sigma!r} is invalid: expected a finite number > 0")
    K = np.exp(-_sq_dists(X, Y) / (2.0 * sigma * sigma))
    if Y is X:
        np.fill_diagonal(K, 1.0)  # exact despite rounding in the squared distances
    return K


def _check_kernel_matrix(K) -> np.ndarray:
    K = np.ascontiguousarray(K, dtype=np.float64)
    if K.ndim != 2 or K.shape[0] != K.shape[1]:
        raise ParameterError(f"kernel matrix must be square (n, n), got shape {K.shape}")
    return K


def dtak_matrix(x, y, *, kernel: str = "equality", sigma: float | None = None) -> np.ndarray:
    """Whole P matrix of eq. 7 between sequences ``x`` (n1, d) and ``y`` (n2, d).

    Returns an (n1, n2) array; ``P[i, j]`` is the paper's ``p_{i+1, j+1}`` (the 0-boundary is
    dropped), so ``P[-1, -1] / (n1 + n2)`` is the DTAK (eq. 6).
    """
    x = _as_frames(x, "x")
    y = _as_frames(y, "y")
    K = frame_kernel(x, y, kernel=kernel, sigma=sigma)
    return dtak_table(np.ascontiguousarray(K), 0, x.shape[0], 0, y.shape[0])[1:, 1:]


def dtak(x, y, *, kernel: str = "equality", sigma: float | None = None) -> float:
    """DTAK (eq. 6) between sequences ``x`` (n1, d) and ``y`` (n2, d); a value in [0, 1]."""
    x = _as_frames(x, "x")
    y = _as_frames(y, "y")
    K = np.ascontiguousarray(frame_kernel(x, y, kernel=kernel, sigma=sigma))
    return float(dtak_pair(K, 0, x.shape[0], 0, y.shape[0], np.empty(y.shape[0] + 1)))


def segment_dtak(K, segments) -> np.ndarray:
    """(m, m) DTAK matrix between segments ``[(start, end), ...]`` of a frame-kernel matrix K."""
    K = _check_kernel_matrix(K)
    seg = np.asarray([(s, e) for s, e, *_ in segments], dtype=np.int64).reshape(-1, 2)
    n = K.shape[0]
    if seg.size and (seg[:, 0].min() < 0 or seg[:, 1].max() > n or np.any(seg[:, 1] <= seg[:, 0])):
        raise ParameterError(f"segments must satisfy 0 <= start < end <= {n}")
    return segment_kernel(K, np.ascontiguousarray(seg[:, 0]), np.ascontiguousarray(seg[:, 1]))
