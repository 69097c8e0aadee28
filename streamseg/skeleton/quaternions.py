"""Joint rotations as hemisphere-continuous quaternions (the ACA paper's mocap features).

ACA (Zhou et al. 2008, section 4.1) follows Barbic et al. (2004) in using "the 14 most
informative joints" as quaternions. We take the 14 rotating segments of the torso and limbs:
lower back, upper back, thorax, neck, and per side clavicle, upper arm, forearm, thigh, shin.
The root is left out on purpose: its rotation carries the walking direction, so the same
action performed facing another way would look different. Hands, feet, fingers and toes are
left out because optical markers there are noisy and they carry little about the action.
"""

from __future__ import annotations

import numpy as np

from streamseg.exceptions import SkeletonError
from streamseg.skeleton.names import SEGMENTS, resolve
from streamseg.skeleton.rotations import continuous_hemisphere, matrix_to_quaternion

ACA_SEGMENTS = (
    "lower_back",
    "upper_back",
    "thorax",
    "neck",
    "l_clavicle",
    "l_upper_arm",
    "l_forearm",
    "r_clavicle",
    "r_upper_arm",
    "r_forearm",
    "l_thigh",
    "l_shin",
    "r_thigh",
    "r_shin",
)


def local_rotations(rotations: np.ndarray, parents, joints=None) -> np.ndarray:
    """Rotation of each joint relative to its parent: ``R_parent.T @ R_joint``.

    Parameters
    ----------
    rotations : ndarray, shape (n_frames, n_joints, 3, 3)
        Global rotations.
    parents : ndarray of int, shape (n_joints,)
    joints : sequence of int, optional
        The joints wanted (default: all); only their products are computed.

    Returns
    -------
    ndarray, shape (n_frames, len(joints), 3, 3); the root keeps its global rotation.
    """
    parents = np.asarray(parents)
    joints = np.arange(rotations.shape[1]) if joints is None else np.asarray(joints)
    out = rotations[:, joints]  # fancy indexing: a copy
    of = parents[joints]
    child = np.flatnonzero(of >= 0)
    out[:, child] = np.swapaxes(rotations[:, of[child]], -1, -2) @ rotations[:, joints[child]]
    return out


def joint_quaternions(recording, segments=ACA_SEGMENTS) -> np.ndarray:
    """Local rotations of ``segments`` as quaternions, continuous over time.

    Returns
    -------
    ndarray of float64, shape (n_frames, len(segments), 4)
        ``(w, x, y, z)``; consecutive frames never flip sign (``q`` and ``-q`` are one rotation).
    """
    if recording.rotations is None:
        raise SkeletonError(
            f"{recording.source or 'this recording'} has joint positions only (no rotations); "
            "use streamseg.skeleton.body_features for position-only streams"
        )
    idx = resolve(recording.skeleton.names, segments, SEGMENTS)
    local = local_rotations(recording.rotations, recording.skeleton.parents, idx)
    return continuous_hemisphere(matrix_to_quaternion(local))


def quaternion_features(recording) -> np.ndarray:
    """The ACA feature matrix: 14 joint quaternions per frame, flattened.

    Returns
    -------
    ndarray of float64, shape (n_frames, 56)
    """
    q = joint_quaternions(recording)
    return q.reshape(len(q), -1)
