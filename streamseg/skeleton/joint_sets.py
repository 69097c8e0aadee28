"""Joint lists of the skeletons that come without names: Kinect v2, BlazePose, COCO-17, BODY_25.

A positions file with no header, or an array of shape ``(n, n_joints, 3)``, names its joints
by order only; ``--joints NAME`` gives them the names of :data:`JOINT_SETS`. Pose models have
no pelvis, spine or neck joint; :func:`complete` adds them as virtual joints (mid-hip,
mid-shoulder, the point half-way between) so that every map reaches the canonical points of
:data:`streamseg.skeleton.names.POINTS`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from streamseg.exceptions import ParameterError, SkeletonError
from streamseg.skeleton.names import POINTS, resolve


@dataclass(frozen=True)
class JointSet:
    """A named joint order.

    Attributes
    ----------
    names : tuple of str
        Joint names in the order the producer writes them.
    up : str
        The producer's world up axis (Kinect camera space: ``y``; BlazePose world landmarks
        and image-derived keypoints: ``-y``, image rows grow downwards).
    units : str
    source : str
        Where the order is defined.
    fixed_up : bool
        The producer writes one frame (Kinect camera space, BlazePose world landmarks): ``up``
        holds. Otherwise (COCO and BODY_25 keypoints come in image, camera or world frames,
        as the lifting or triangulating tool chose) the up axis is the one the body stands
        along, ``up`` when no axis is clear.
    """

    names: tuple
    up: str
    units: str
    source: str
    fixed_up: bool = True


KINECT_V2 = JointSet(
    (
        "SpineBase",
        "SpineMid",
        "Neck",
        "Head",
        "ShoulderLeft",
        "ElbowLeft",
        "WristLeft",
        "HandLeft",
        "ShoulderRight",
        "ElbowRight",
        "WristRight",
        "HandRight",
        "HipLeft",
        "KneeLeft",
        "AnkleLeft",
        "FootLeft",
        "HipRight",
        "KneeRight",
        "AnkleRight",
        "FootRight",
        "SpineShoulder",
        "HandTipLeft",
        "ThumbLeft",
        "HandTipRight",
        "ThumbRight",
    ),
    "y",
    "m",
    "Kinect for Windows SDK 2.0, JointType enumeration (camera space, metres)",
)

BLAZEPOSE = JointSet(
    (
        "nose",
        "left_eye_inner",
        "left_eye",
        "left_eye_outer",
        "right_eye_inner",
        "right_eye",
        "right_eye_outer",
        "left_ear",
        "right_ear",
        "mouth_left",
        "mouth_right",
        "left_shoulder",
        "right_shoulder",
        "left_elbow",
        "right_elbow",
        "left_wrist",
        "right_wrist",
        "left_pinky",
        "right_pinky",
        "left_index",
        "right_index",
        "left_thumb",
        "right_thumb",
        "left_hip",
        "right_hip",
        "left_knee",
        "right_knee",
        "left_ankle",
        "right_ankle",
        "left_heel",
        "right_heel",
        "left_foot_index",
        "right_foot_index",
    ),
    "-y",
    "m",
    "MediaPipe Pose (BlazePose) landmarks 0-32; pose_world_landmarks are metres "
    "about the hips' centre, y down",
)

COCO17 = JointSet(
    (
        "nose",
        "left_eye",
        "right_eye",
        "left_ear",
        "right_ear",
        "left_shoulder",
        "right_shoulder",
        "left_elbow",
        "right_elbow",
        "left_wrist",
        "right_wrist",
        "left_hip",
        "right_hip",
        "left_knee",
        "right_knee",
        "left_ankle",
        "right_ankle",
    ),
    "-y",
    "unknown",
    "COCO keypoints (person_keypoints), 17 in their order",
    fixed_up=False,
)

BODY25 = JointSet(
    (
        "Nose",
        "Neck",
        "RShoulder",
        "RElbow",
        "RWrist",
        "LShoulder",
        "LElbow",
        "LWrist",
        "MidHip",
        "RHip",
        "RKnee",
        "RAnkle",
        "LHip",
        "LKnee",
        "LAnkle",
        "REye",
        "LEye",
        "REar",
        "LEar",
        "LBigToe",
        "LSmallToe",
        "LHeel",
        "RBigToe",
        "RSmallToe",
        "RHeel",
    ),
    "-y",
    "unknown",
    "OpenPose BODY_25 keypoints (output/keypoints JSON order)",
    fixed_up=False,
)

#: ``--joints`` values.
JOINT_SETS = {"kinect": KINECT_V2, "blazepose": BLAZEPOSE, "coco17": COCO17, "body25": BODY25}


def joint_set(name: str) -> JointSet:
    """The :data:`JOINT_SETS` entry ``name`` (case free); a ParameterError lists them."""
    try:
        return JOINT_SETS[name.lower()]
    except KeyError:
        raise ParameterError(
            f"--joints {name}: unknown joint set; expected one of {', '.join(JOINT_SETS)}"
        ) from None


def sets_of_size(n_joints: int) -> list[str]:
    """Names of the joint sets with ``n_joints`` joints (for a hint)."""
    return [k for k, v in JOINT_SETS.items() if len(v.names) == n_joints]


# virtual point -> (canonical points it is the mean of, weights)
_VIRTUAL = {
    "pelvis": (("l_hip", "r_hip"), (0.5, 0.5)),
    "neck": (("l_shoulder", "r_shoulder"), (0.5, 0.5)),
    "sternum": (("l_shoulder", "r_shoulder"), (0.5, 0.5)),
    "spine": (("l_hip", "r_hip", "l_shoulder", "r_shoulder"), (0.25, 0.25, 0.25, 0.25)),
}


def complete(names, positions: np.ndarray):
    """Add the trunk points a skeleton lacks as virtual joints.

    The pelvis is the hips' midpoint, the neck and sternum the shoulders' midpoint and the
    spine half-way between: the trunk direction of a pose model's keypoints.

    Parameters
    ----------
    names : sequence of str
    positions : ndarray, shape (n_frames, n_joints, 3)

    Returns
    -------
    names : tuple of str
        ``names`` followed by any virtual joint added (``pelvis``, ``spine``, ``neck``,
        ``sternum``).
    positions : ndarray, shape (n_frames, n_joints + added, 3)
    """
    names = tuple(names)
    added, columns, done = [], [], []
    for point, (parts, weights) in _VIRTUAL.items():
        try:  # together with the points before it: no joint serves two points
            resolve(names + tuple(added), (*done, point), POINTS)
            done.append(point)
            continue
        except SkeletonError:
            pass
        try:
            idx = resolve(names, parts, POINTS)
        except SkeletonError:
            continue  # not even the limbs: the caller's resolve says what is missing
        columns.append(sum(w * positions[:, i] for w, i in zip(weights, idx)))
        added.append(point)
        done.append(point)
    if not added:
        return names, positions
    return names + tuple(added), np.concatenate([positions, np.stack(columns, axis=1)], axis=1)
