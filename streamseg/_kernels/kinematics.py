"""Acclaim forward kinematics (numba). Private: :func:`streamseg.io.amc.pose` checks and
prepares the skeleton's arrays; the definition is its docstring."""

from __future__ import annotations

import math

from numba import njit

#: a dof's kind: rotation about x, y, z (0-2), translation along x, y, z (3-5), or a
#: channel that moves nothing (Acclaim's ``l``, bone length)
TRANSLATION = 3
IGNORED = 6


@njit(cache=True, nogil=True)
def _rotate_about(axis, angle, m):
    """``m = R_axis(angle) @ m`` in place (a right-handed rotation of the rows)."""
    c, s = math.cos(angle), math.sin(angle)
    j, k = (axis + 1) % 3, (axis + 2) % 3
    for col in range(3):
        a, b = m[j, col], m[k, col]
        m[j, col] = c * a - s * b
        m[k, col] = s * a + c * b


@njit(cache=True, nogil=True)
def pose_frames(values, parents, kinds, cols, frames, offsets, root, to_rad, scale, inch, pos, rot):
    """World positions and rotations of every bone in every frame.

    Parameters
    ----------
    values : float64 (n, v)
        The frames' channel values (degrees or radians, the file's length unit).
    parents : int64 (b,)
        Parent bone of each bone, -1 for the root; parents precede children.
    kinds, cols : int64 (b, w)
        Each bone's dofs in the order they apply: kind (0-2 rotation about x/y/z,
        3-5 translation, 6 ignored), the column of ``values``; kind -1 ends the list.
    frames : float64 (b, 3, 3)
        Each bone's ASF ``axis`` frame ``C``.
    offsets : float64 (b, 3)
        ``direction * length`` of each bone, metres.
    root : float64 (3,)
        The root's position before translation, metres.
    to_rad, scale, inch : float
        Angle values to radians; translation values to metres: ``value / scale * inch``
        (the ASF's length scale; metres per inch).
    pos : float64 (n, b, 3), written
    rot : float64 (n, b, 3, 3), written
    """
    n, n_bones = values.shape[0], parents.shape[0]
    m = frames[0].copy()
    local = frames[0].copy()
    cm = frames[0].copy()
    for t in range(n):
        for i in range(n_bones):
            for r in range(3):
                for c in range(3):
                    m[r, c] = 1.0 if r == c else 0.0
            sx, sy, sz = root[0], root[1], root[2]
            for d in range(kinds.shape[1]):
                kind = kinds[i, d]
                if kind < 0:
                    break
                if kind == IGNORED:
                    continue
                v = values[t, cols[i, d]]
                if kind < TRANSLATION:
                    _rotate_about(kind, v * to_rad, m)
                elif kind == TRANSLATION:
                    sx += v / scale * inch
                elif kind == TRANSLATION + 1:
                    sy += v / scale * inch
                else:
                    sz += v / scale * inch
            C = frames[i]
            for r in range(3):  # C @ M @ C.T
                for c in range(3):
                    cm[r, c] = C[r, 0] * m[0, c] + C[r, 1] * m[1, c] + C[r, 2] * m[2, c]
            for r in range(3):
                for c in range(3):
                    local[r, c] = cm[r, 0] * C[c, 0] + cm[r, 1] * C[c, 1] + cm[r, 2] * C[c, 2]
            p = parents[i]
            if p < 0:
                for r in range(3):
                    for c in range(3):
                        rot[t, i, r, c] = local[r, c]
                pos[t, i, 0], pos[t, i, 1], pos[t, i, 2] = sx, sy, sz
                continue
            for r in range(3):
                for c in range(3):
                    rot[t, i, r, c] = (
                        rot[t, p, r, 0] * local[0, c]
                        + rot[t, p, r, 1] * local[1, c]
                        + rot[t, p, r, 2] * local[2, c]
                    )
            for r in range(3):
                pos[t, i, r] = pos[t, p, r] + (
                    rot[t, i, r, 0] * offsets[i, 0]
                    + rot[t, i, r, 1] * offsets[i, 1]
                    + rot[t, i, r, 2] * offsets[i, 2]
                )
