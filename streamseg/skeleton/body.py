"""Position-only pose features in a body-centred frame (for streams that carry no rotations)."""

from __future__ import annotations

import numpy as np

from streamseg.skeleton.names import POINTS, resolve

LIMBS = (
    ("l_shoulder", "l_elbow"),
    ("l_elbow", "l_wrist"),
    ("r_shoulder", "r_elbow"),
    ("r_elbow", "r_wrist"),
    ("l_hip", "l_knee"),
    ("l_knee", "l_ankle"),
    ("r_hip", "r_knee"),
    ("r_knee", "r_ankle"),
    ("pelvis", "neck"),
)


def body_frame(positions: np.ndarray, skeleton) -> np.ndarray:
    """Per-frame body axes: x from right hip to left hip, y up the spine, z = x cross y.

    Returns
    -------
    ndarray, shape (n_frames, 3, 3); rows are the unit axes in world coordinates.
    """
    pel, neck, lh, rh = resolve(skeleton.names, ("pelvis", "neck", "l_hip", "r_hip"), POINTS)
    x = positions[:, lh] - positions[:, rh]
    up = positions[:, neck] - positions[:, pel]
    with np.errstate(invalid="ignore", divide="ignore"):
        y = up / np.linalg.norm(up, axis=1, keepdims=True)
        x = x - np.sum(x * y, axis=1, keepdims=True) * y
        x /= np.linalg.norm(x, axis=1, keepdims=True)
    z = np.cross(x, y)
    return np.stack([x, y, z], axis=1)


def body_features(positions: np.ndarray, skeleton) -> np.ndarray:
    """Unit directions of 8 limb bones and the trunk, in the body frame.

    Heading-invariant (turning round does not change them) and scale-invariant (bone lengths
    divide out), so they compare poses across people and facing directions. The trunk
    direction is expressed in the world frame's vertical only (its angle to up), since in the
    body frame it is the y axis by construction.

    Parameters
    ----------
    positions : ndarray, shape (n_frames, n_joints, 3)
    skeleton : Skeleton

    Returns
    -------
    ndarray of float64, shape (n_frames, 25): 8 limbs x 3 components, then the trunk's
    cosine to the world up axis (the skeleton's ``up``, ``"y"`` for a list of names).
    """
    from streamseg.skeleton.bones import up_vector

    positions = np.asarray(positions, dtype=np.float64)
    names = [p for limb in LIMBS for p in limb]
    idx = resolve(skeleton.names, tuple(dict.fromkeys(names)), POINTS)
    where = dict(zip(dict.fromkeys(names), idx))
    axes = body_frame(positions, skeleton)
    out = []
    for a, b in LIMBS[:-1]:
        v = positions[:, where[b]] - positions[:, where[a]]
        with np.errstate(invalid="ignore", divide="ignore"):
            v = v / np.linalg.norm(v, axis=1, keepdims=True)
        out.append(np.einsum("nij,nj->ni", axes, v))
    trunk = positions[:, where["neck"]] - positions[:, where["pelvis"]]
    with np.errstate(invalid="ignore", divide="ignore"):
        up = up_vector(getattr(skeleton, "up", "y"))
        out.append((trunk @ up / np.linalg.norm(trunk, axis=1))[:, None])
    return np.concatenate(out, axis=1)
