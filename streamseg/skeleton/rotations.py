"""Rotation helpers, vectorized over frames: Euler angles, matrices, quaternions."""

from __future__ import annotations

import numpy as np

_AXIS = {"x": 0, "y": 1, "z": 2}


def axis_rotation(axis: str, angle: np.ndarray) -> np.ndarray:
    """Right-handed rotation about one coordinate axis.

    Parameters
    ----------
    axis : {"x", "y", "z"}
    angle : ndarray, shape (n,)
        Angles in radians.

    Returns
    -------
    ndarray, shape (n, 3, 3)
    """
    angle = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(angle.shape + (3, 3))
    i = _AXIS[axis.lower()]
    j, k = (i + 1) % 3, (i + 2) % 3
    out[..., i, i] = 1.0
    out[..., j, j] = c
    out[..., k, k] = c
    out[..., j, k] = -s
    out[..., k, j] = s
    return out


def euler_to_matrix(angles: np.ndarray, order: str) -> np.ndarray:
    """Compose rotations applied in ``order`` (first letter first): ``R = R_last @ ... @ R_first``.

    This is the Acclaim and BVH convention: for order ``"xyz"`` a vector is rotated about x,
    then y, then z, so ``R = Rz @ Ry @ Rx``.

    Parameters
    ----------
    angles : ndarray, shape (n, len(order))
        Radians, one column per letter of ``order``.
    order : str
        Axis letters, e.g. ``"xyz"`` or ``"zx"``.

    Returns
    -------
    ndarray, shape (n, 3, 3)
    """
    angles = np.atleast_2d(np.asarray(angles, dtype=np.float64))
    out = np.broadcast_to(np.eye(3), (angles.shape[0], 3, 3)).copy()
    for col, axis in enumerate(order):
        out = axis_rotation(axis, angles[:, col]) @ out
    return out


def matrix_to_quaternion(m: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(w, x, y, z)`` of rotation matrices (Shepperd's method, stable).

    Parameters
    ----------
    m : ndarray, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 4), with ``w >= 0`` before any hemisphere alignment.
    """
    m = np.asarray(m, dtype=np.float64)
    shape = m.shape[:-2]
    m = m.reshape(-1, 3, 3)
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    # Candidates 4*q_i^2 for each component; use the largest for numerical stability.
    cand = np.stack(
        [1 + tr, 1 + 2 * m[:, 0, 0] - tr, 1 + 2 * m[:, 1, 1] - tr, 1 + 2 * m[:, 2, 2] - tr], axis=1
    )
    best = np.argmax(cand, axis=1)
    q = np.empty((m.shape[0], 4))
    r = np.sqrt(np.maximum(cand[np.arange(len(best)), best], 1e-300))
    w = best == 0
    q[w, 0] = 0.5 * r[w]
    q[w, 1] = (m[w, 2, 1] - m[w, 1, 2]) / (2 * r[w])
    q[w, 2] = (m[w, 0, 2] - m[w, 2, 0]) / (2 * r[w])
    q[w, 3] = (m[w, 1, 0] - m[w, 0, 1]) / (2 * r[w])
    x = best == 1
    q[x, 0] = (m[x, 2, 1] - m[x, 1, 2]) / (2 * r[x])
    q[x, 1] = 0.5 * r[x]
    q[x, 2] = (m[x, 0, 1] + m[x, 1, 0]) / (2 * r[x])
    q[x, 3] = (m[x, 0, 2] + m[x, 2, 0]) / (2 * r[x])
    y = best == 2
    q[y, 0] = (m[y, 0, 2] - m[y, 2, 0]) / (2 * r[y])
    q[y, 1] = (m[y, 0, 1] + m[y, 1, 0]) / (2 * r[y])
    q[y, 2] = 0.5 * r[y]
    q[y, 3] = (m[y, 1, 2] + m[y, 2, 1]) / (2 * r[y])
    z = best == 3
    q[z, 0] = (m[z, 1, 0] - m[z, 0, 1]) / (2 * r[z])
    q[z, 1] = (m[z, 0, 2] + m[z, 2, 0]) / (2 * r[z])
    q[z, 2] = (m[z, 1, 2] + m[z, 2, 1]) / (2 * r[z])
    q[z, 3] = 0.5 * r[z]
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return q.reshape(shape + (4,))


def continuous_hemisphere(q: np.ndarray) -> np.ndarray:
    """Flip signs so consecutive quaternions lie in the same hemisphere (q and -q are one rotation).

    Parameters
    ----------
    q : ndarray, shape (n_frames, ..., 4)

    Returns
    -------
    ndarray, same shape; ``dot(q[t], q[t-1]) >= 0`` for every t and joint.
    """
    q = np.array(q, dtype=np.float64, copy=True)
    if len(q) < 2:
        return q
    dots = np.sum(q[1:] * q[:-1], axis=-1)
    # A flip at t propagates to every later frame: cumulative parity of the sign changes.
    flips = np.cumprod(np.where(dots < 0, -1.0, 1.0), axis=0)
    q[1:] *= flips[..., None]
    return q
