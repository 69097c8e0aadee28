"""The LOF paper's 9 bones and 8 bone angles (Xing et al. 2015, Tables 1 and 2)."""

from __future__ import annotations

import numpy as np

from streamseg._kernels.bones import angles_kernel
from streamseg.skeleton.names import POINTS, resolve

# Table 1: bone = (parent point, child point); vectors point from parent to child.
BONES = (
    ("pelvis", "spine"),  # Bone1 root->lowerback
    ("l_shoulder", "l_elbow"),  # Bone2 lclavicle->lhumerus (upper arm)
    ("l_elbow", "l_wrist"),  # Bone3 lhumerus->lradius (forearm)
    ("r_shoulder", "r_elbow"),  # Bone4
    ("r_elbow", "r_wrist"),  # Bone5
    ("l_hip", "l_knee"),  # Bone6 lhip->lfemur (thigh)
    ("l_knee", "l_ankle"),  # Bone7 lfemur->ltibia (shin)
    ("r_hip", "r_knee"),  # Bone8
    ("r_knee", "r_ankle"),  # Bone9
)
# Table 2, 0-based bone indices.
ANGLES = ((0, 1), (0, 3), (0, 5), (0, 7), (1, 2), (3, 4), (5, 6), (7, 8))
ANGLE_NAMES = (
    "spine-l_upper_arm",
    "spine-r_upper_arm",
    "spine-l_thigh",
    "spine-r_thigh",
    "l_elbow",
    "r_elbow",
    "l_knee",
    "r_knee",
)
POINT_NAMES = tuple(dict.fromkeys(p for bone in BONES for p in bone))


def bone_point_indices(skeleton) -> np.ndarray:
    """Joint indices of the bone end points, shape (9, 2) (parent point, child point)."""
    names = skeleton.names if hasattr(skeleton, "names") else skeleton
    idx = dict(zip(POINT_NAMES, resolve(names, POINT_NAMES, POINTS)))
    return np.array([[idx[a], idx[b]] for a, b in BONES])


def bone_angles(positions: np.ndarray, skeleton) -> np.ndarray:
    """The 8 bone angles of every frame.

    Eq. (1) of the paper writes ``Bone1 = P_root - P_lowerback`` while Table 1 and its text say
    bones point from parent to child; we follow the table. (Either way the angle is mirrored
    about pi/2, which permutes equal-width histogram bins and leaves cosine distances and LOF
    unchanged.)

    Parameters
    ----------
    positions : ndarray, shape (n_frames, n_joints, 3)
    skeleton : Skeleton or sequence of joint names

    Returns
    -------
    ndarray of float64, shape (n_frames, 8)
        Radians in [0, pi]; a frame with a NaN joint (marker dropout) or a zero-length bone
        gives NaN in the angles it touches.
    """
    return angles_at(positions, bone_point_indices(skeleton))


_FIRST = np.array([i for i, _ in ANGLES], dtype=np.int64)
_SECOND = np.array([j for _, j in ANGLES], dtype=np.int64)


def angles_at(positions: np.ndarray, points: np.ndarray) -> np.ndarray:
    """:func:`bone_angles` with the bone end points already resolved (a live stream resolves
    them once, at announcement).

    Parameters
    ----------
    positions : ndarray, shape (n_frames, n_joints, 3)
    points : ndarray of int, shape (9, 2)
        From :func:`bone_point_indices`.

    Returns
    -------
    ndarray of float64, shape (n_frames, 8)
    """
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    if positions.ndim != 3 or positions.shape[2] != 3:
        raise ValueError(f"positions has shape {positions.shape}; expected (n_frames, n_joints, 3)")
    points = np.asarray(points, dtype=np.int64)
    if points.shape != (len(BONES), 2) or points.min() < 0 or points.max() >= positions.shape[1]:
        raise ValueError(f"points {points.tolist()} do not index the {positions.shape[1]} joints")
    return angles_kernel(positions, np.ascontiguousarray(points[:, 0]),
                         np.ascontiguousarray(points[:, 1]), _FIRST, _SECOND)
