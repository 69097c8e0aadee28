"""Frame arrays in, feature arrays out: bones, bone angles, quaternions, body-frame directions."""

from __future__ import annotations

from streamseg.skeleton.body import body_features, body_frame
from streamseg.skeleton.bones import ANGLE_NAMES, BONES, bone_angles
from streamseg.skeleton.names import POINTS, SEGMENTS, resolve
from streamseg.skeleton.quaternions import ACA_SEGMENTS, joint_quaternions, quaternion_features

__all__ = [
    "ACA_SEGMENTS",
    "ANGLE_NAMES",
    "BONES",
    "POINTS",
    "SEGMENTS",
    "body_features",
    "body_frame",
    "bone_angles",
    "joint_quaternions",
    "quaternion_features",
    "resolve",
]
