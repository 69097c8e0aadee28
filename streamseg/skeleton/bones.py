"""The LOF paper's 9 bones and 8 bone angles (Xing et al. 2015, Tables 1 and 2), and the
9 bones' inclinations from the vertical that streamseg's LOF adds to them."""

from __future__ import annotations

import numpy as np

from streamseg._kernels.bones import angles_kernel
from streamseg.exceptions import ParameterError
from streamseg.recording import UP_AXES
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
# Each bone against the vertical (the pseudo-bone len(BONES)): the paper's angles are all
# between two bones, so they cannot tell a pose from the same pose tilted (standing from
# bending over or lying, an arm held up from held forward); gravity can, whatever the heading.
INCLINATIONS = tuple((b, len(BONES)) for b in range(len(BONES)))
INCLINATION_NAMES = (
    "spine_incl",
    "l_upper_arm_incl",
    "l_forearm_incl",
    "r_upper_arm_incl",
    "r_forearm_incl",
    "l_thigh_incl",
    "l_shin_incl",
    "r_thigh_incl",
    "r_shin_incl",
)
FEATURE_NAMES = ANGLE_NAMES + INCLINATION_NAMES
POINT_NAMES = tuple(dict.fromkeys(p for bone in BONES for p in bone))


def up_vector(up: str) -> np.ndarray:
    """The unit vector of an up-axis name (``"y"``, ``"-z"``, ...), float64 shape (3,)."""
    if up not in UP_AXES:
        raise ParameterError(f"up={up!r} is invalid: expected one of {', '.join(UP_AXES)}")
    v = np.zeros(3)
    v["xyz".index(up[-1])] = -1.0 if up.startswith("-") else 1.0
    return v


def likely_up(spine: np.ndarray, up: str) -> str | None:
    """The axis a body's spine points along when that is clearly not the declared ``up``.

    Parameters
    ----------
    spine : ndarray, shape (3,)
        Sum (or mean) of unit pelvis-to-spine vectors over some frames.
    up : str
        The declared up axis.

    Returns
    -------
    str or None
        An axis name of :data:`UP_AXES` when the mean spine is more than 60 degrees from
        ``up`` and within 37 degrees of that axis (someone standing in a frame whose up axis
        was not declared); None otherwise, including when there is no clear axis (lying,
        tilted, no data).
    """
    norm = float(np.linalg.norm(spine))
    if not (np.isfinite(norm) and norm > 0):
        return None
    v = np.asarray(spine, dtype=np.float64) / norm
    if v @ up_vector(up) >= 0.5:
        return None
    best = max(UP_AXES, key=lambda a: float(v @ up_vector(a)))
    return best if v @ up_vector(best) >= 0.8 else None


def spine_directions(positions: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Sum of the unit pelvis-to-spine vectors of the finite frames, shape (3,), and their
    count, for :func:`likely_up` (``points`` from :func:`bone_point_indices`)."""
    v = positions[:, points[0, 1]] - positions[:, points[0, 0]]
    with np.errstate(invalid="ignore", divide="ignore"):
        v = v / np.linalg.norm(v, axis=1, keepdims=True)
    ok = np.isfinite(v).all(axis=1)
    return v[ok].sum(axis=0), int(ok.sum())


def bone_point_indices(skeleton) -> np.ndarray:
    """Joint indices of the bone end points, shape (9, 2) (parent point, child point)."""
    names = skeleton.names if hasattr(skeleton, "names") else skeleton
    idx = dict(zip(POINT_NAMES, resolve(names, POINT_NAMES, POINTS)))
    return np.array([[idx[a], idx[b]] for a, b in BONES])


def bone_angles(
    positions: np.ndarray, skeleton, inclinations: bool = True, up: str | None = None
) -> np.ndarray:
    """The 8 bone angles of every frame, followed (by default) by the 9 bone inclinations.

    The default gives the 17 features the cut detector expects (``LOFConfig.inclinations``);
    ``inclinations=False`` gives the paper's 8 angles.

    Eq. (1) of the paper writes ``Bone1 = P_root - P_lowerback`` while Table 1 and its text say
    bones point from parent to child; we follow the table. (Either way the angle is mirrored
    about pi/2, which permutes equal-width histogram bins and leaves cosine distances and LOF
    unchanged.)

    Parameters
    ----------
    positions : ndarray, shape (n_frames, n_joints, 3)
    skeleton : Skeleton or sequence of joint names
    inclinations : bool, default True
        Append each bone's angle from the up axis (:data:`INCLINATION_NAMES`).
    up : str or None
        Up axis of the positions (:data:`UP_AXES`); None: the skeleton's ``up`` (``"y"`` for
        a list of names, the Acclaim/BVH/Kinect convention).

    Returns
    -------
    ndarray of float64, shape (n_frames, 8) or (n_frames, 17) with inclinations
        Radians in [0, pi]; a frame with a NaN joint (marker dropout) or a zero-length bone
        gives NaN in the angles it touches.
    """
    if up is None:
        up = getattr(skeleton, "up", "y")
    return angles_at(
        positions, bone_point_indices(skeleton), up_vector(up) if inclinations else None
    )


_FIRST = np.array([i for i, _ in ANGLES + INCLINATIONS], dtype=np.int64)
_SECOND = np.array([j for _, j in ANGLES + INCLINATIONS], dtype=np.int64)
_NO_UP = np.zeros(3)


def angles_at(positions: np.ndarray, points: np.ndarray, up=None) -> np.ndarray:
    """:func:`bone_angles` with the bone end points already resolved (a live stream resolves
    them once, at announcement).

    Parameters
    ----------
    positions : ndarray, shape (n_frames, n_joints, 3)
    points : ndarray of int, shape (9, 2)
        From :func:`bone_point_indices`.
    up : str, array_like of shape (3,), or None
        Up axis (a name, :func:`up_vector`, or a nonzero vector, normalized here): append the
        9 inclinations; None: the 8 angles only.

    Returns
    -------
    ndarray of float64, shape (n_frames, 8) or (n_frames, 17)
    """
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    if positions.ndim != 3 or positions.shape[2] != 3:
        raise ParameterError(
            f"positions has shape {positions.shape}; expected (n_frames, n_joints, 3)"
        )
    points = np.asarray(points, dtype=np.int64)
    if points.shape != (len(BONES), 2) or points.min() < 0 or points.max() >= positions.shape[1]:
        raise ParameterError(
            f"points {points.tolist()} do not index the {positions.shape[1]} joints"
        )
    if up is None:
        m, up = len(ANGLES), _NO_UP
    else:
        m, up = len(ANGLES) + len(INCLINATIONS), _unit(up)
    return angles_kernel(
        positions,
        np.ascontiguousarray(points[:, 0]),
        np.ascontiguousarray(points[:, 1]),
        _FIRST[:m],
        _SECOND[:m],
        up,
    )


def _unit(up) -> np.ndarray:
    """``up`` as a unit float64 (3,) vector; a name goes through :func:`up_vector`."""
    if isinstance(up, str):
        return up_vector(up)
    v = np.asarray(up, dtype=np.float64)
    norm = float(np.linalg.norm(v)) if v.shape == (3,) else 0.0
    if not (np.isfinite(norm) and norm > 0):
        raise ParameterError(
            f"up={up!r} is invalid: expected an axis name ({', '.join(UP_AXES)}) "
            "or a finite nonzero 3-vector"
        )
    return v / norm


def upright_axis(positions: np.ndarray, skeleton) -> str | None:
    """The axis of :data:`UP_AXES` the body stands along (pelvis to neck, mean over the
    finite frames) when it is within 37 degrees of it; None when no axis is that clear (or
    fewer than 10 frames, or the trunk points cannot be named).

    Parameters
    ----------
    positions : ndarray, shape (n_frames, n_joints, 3)
    skeleton : Skeleton or sequence of joint names
    """
    from streamseg.exceptions import SkeletonError

    names = skeleton.names if hasattr(skeleton, "names") else skeleton
    try:
        pelvis, neck = resolve(names, ("pelvis", "neck"), POINTS)
    except SkeletonError:
        return None
    trunk = positions[:, neck] - positions[:, pelvis]
    with np.errstate(invalid="ignore", divide="ignore"):
        trunk = trunk / np.linalg.norm(trunk, axis=1, keepdims=True)
    ok = np.isfinite(trunk).all(axis=1)
    if ok.sum() < 10:
        return None
    mean = trunk[ok].mean(axis=0)
    best = max(UP_AXES, key=lambda a: float(mean @ up_vector(a)))
    return best if mean @ up_vector(best) >= 0.8 * np.linalg.norm(mean) else None
