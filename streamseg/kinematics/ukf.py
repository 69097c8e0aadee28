"""A small unscented Kalman filter for random-walk states, vectorised over sigma points.

Why not a library: filterpy (the usual choice) loops over sigma points in Python, still
declares Python 2.7-3.6 support and would be a new core dependency; the filter needed here is
~60 lines of numpy. The sigma points use the symmetric rule (alpha=1, beta=0, kappa=0: 2n
points at +-sqrt(n) standard deviations, equal weights 1/(2n), no centre point). All weights
are positive, so the predicted covariances stay positive definite, which the scaled UKF with
a large negative centre weight does not guarantee in 30+ dimensions.

The state evolves as a random walk (paper eq. 6 forward, eq. 8 backward), so prediction is
``P += Q``; only the measurement function is nonlinear.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from streamseg.exceptions import ParameterError

__all__ = ["ukf_pass", "ukf_update"]


def ukf_update(x, P, y, h, R):
    """One measurement update.

    Parameters
    ----------
    x : ndarray, shape (d,)
        Predicted state mean.
    P : ndarray, shape (d, d)
        Predicted state covariance (positive definite).
    y : ndarray, shape (m,)
        Measurement; NaN entries are ignored (missing markers).
    h : callable
        ``h(X) -> Y`` mapping states ``(s, d)`` to measurements ``(s, m)``.
    R : ndarray, shape (m,)
        Measurement noise variances (diagonal).

    Returns
    -------
    x, P : ndarray, shapes (d,) and (d, d)
        Posterior mean and covariance.
    """
    d = x.shape[0]
    try:
        L = np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        # Round-off can make P indefinite after many updates; symmetrise and add jitter.
        P = 0.5 * (P + P.T) + 1e-9 * np.eye(d)
        L = np.linalg.cholesky(P)
    dev = np.sqrt(d) * np.concatenate([L.T, -L.T])  # (2d, d) offsets, rows are sigma deltas
    Y = h(x + dev)
    ok = np.isfinite(y)
    if not ok.all():
        if not ok.any():
            return x, P
        Y, y, R = Y[:, ok], y[ok], R[ok]
    ym = Y.mean(axis=0)
    dY = Y - ym
    w = 1.0 / (2 * d)
    Pyy = w * (dY.T @ dY) + np.diag(R)
    Pxy = w * (dev.T @ dY)  # the sigma offsets have zero mean by symmetry
    K = np.linalg.solve(Pyy, Pxy.T).T  # Pyy is symmetric
    x = x + K @ (y - ym)
    P = P - K @ Pxy.T
    return x, 0.5 * (P + P.T)


def ukf_pass(
    Y: np.ndarray,
    h: Callable[[np.ndarray], np.ndarray],
    x0: np.ndarray,
    P0: np.ndarray,
    Q: np.ndarray,
    R: np.ndarray,
    *,
    reverse: bool = False,
    max_std: np.ndarray | None = None,
):
    """Filter a whole sequence with a random-walk state (one pass of the four-pass scheme).

    Parameters
    ----------
    Y : ndarray, shape (n, m)
        Measurements per frame (NaN = missing).
    h : callable
        Vectorised measurement function ``(s, d) -> (s, m)``.
    x0 : ndarray, shape (d,)
        State mean before the first processed frame.
    P0 : ndarray, shape (d, d)
        Its covariance.
    Q : ndarray, shape (d,)
        Per-frame random-walk variances (0 fixes a component, e.g. bone lengths in passes 3-4).
    R : ndarray, shape (m,)
        Measurement noise variances.
    reverse : bool
        Run from the last frame to the first (eq. 8) instead of forwards (eq. 6).
    max_std : ndarray, shape (d,), optional
        Upper bound on each component's predicted standard deviation; larger ones are scaled
        down (``P <- D P D`` with diagonal ``D``, which keeps ``P`` positive definite).

    Returns
    -------
    X : ndarray, shape (n, d)
        Filtered state means, in frame order whatever the direction.
    x_last, P_last : ndarray
        Mean and covariance after the last processed frame (to start the next pass).
    """
    Y = np.asarray(Y, dtype=np.float64)
    if Y.ndim != 2:
        raise ParameterError(f"Y must be (n_frames, n_measurements); got shape {Y.shape}")
    x = np.asarray(x0, dtype=np.float64).copy()
    P = np.asarray(P0, dtype=np.float64).copy()
    Qm = np.diag(np.asarray(Q, dtype=np.float64))
    R = np.asarray(R, dtype=np.float64)
    n = Y.shape[0]
    X = np.empty((n, x.shape[0]))
    order = range(n - 1, -1, -1) if reverse else range(n)
    cap = None if max_std is None else np.asarray(max_std, dtype=np.float64)
    for t in order:
        P = P + Qm
        if cap is not None:
            std = np.sqrt(np.diag(P))
            if np.any(std > cap):
                D = np.minimum(1.0, cap / std)
                P = P * D[:, None] * D[None, :]
        x, P = ukf_update(x, P, Y[t], h, R)
        X[t] = x
    return X, x, P
