"""Features from joint positions and rotations, across skeleton naming conventions."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from streamseg.exceptions import SkeletonError
from streamseg.io import read
from streamseg.recording import Recording, Skeleton
from streamseg.skeleton import body_features, bone_angles, quaternion_features
from streamseg.skeleton.rotations import (
    continuous_hemisphere,
    euler_to_matrix,
    matrix_to_quaternion,
)

KINECT = (
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
)


@pytest.fixture(scope="module")
def cmu86(data_dir):
    return read(data_dir / "cmu86/86_01.amc.gz", skeleton=data_dir / "cmu86/86.asf")


def test_kinect_names_reach_the_same_angles(cmu86):
    """Copy the CMU points the features use into a Kinect v2 layout: same angles."""
    src = {
        "SpineBase": "root",
        "SpineMid": "lowerback",
        "Neck": "lowerneck",
        "ShoulderLeft": "lclavicle",
        "ElbowLeft": "lhumerus",
        "WristLeft": "lradius",
        "ShoulderRight": "rclavicle",
        "ElbowRight": "rhumerus",
        "WristRight": "rradius",
        "HipLeft": "lhipjoint",
        "KneeLeft": "lfemur",
        "AnkleLeft": "ltibia",
        "HipRight": "rhipjoint",
        "KneeRight": "rfemur",
        "AnkleRight": "rtibia",
    }
    names = cmu86.skeleton.names
    pos = np.zeros((200, len(KINECT), 3))
    for k, joint in enumerate(KINECT):
        if joint in src:
            pos[:, k] = cmu86.positions[:200, names.index(src[joint])]
    skel = Skeleton(KINECT, np.full(len(KINECT), -1), np.zeros((len(KINECT), 3)), "m")
    np.testing.assert_allclose(
        bone_angles(pos, skel, inclinations=False),
        bone_angles(cmu86.positions[:200], cmu86.skeleton, inclinations=False),
    )
    np.testing.assert_allclose(
        body_features(pos, skel), body_features(cmu86.positions[:200], cmu86.skeleton)
    )


def test_unknown_skeleton_lists_missing_joints():
    skel = Skeleton(("pelvis", "spine", "head"), np.array([-1, 0, 1]), np.zeros((3, 3)))
    with pytest.raises(SkeletonError) as info:
        bone_angles(np.zeros((2, 3, 3)), skel)
    msg = str(info.value)
    for joint in ("l_shoulder", "l_elbow", "r_knee", "r_ankle"):
        assert joint in msg
    assert "Its joints: pelvis, spine, head" in msg


def test_bone_angle_range_and_nan_dropout(cmu86):
    pos = cmu86.positions[:300].copy()
    pos[100, 5] = np.nan  # a marker dropout on one joint (rfemur = knee)
    a = bone_angles(pos, cmu86.skeleton, inclinations=False)
    finite = a[np.isfinite(a)]
    assert finite.min() >= 0 and finite.max() <= np.pi
    assert np.isnan(a[100]).any() and np.isfinite(a[99]).all() and np.isfinite(a[101]).all()


def test_quaternions_continuous_on_real_data(cmu86):
    q = quaternion_features(cmu86).reshape(cmu86.n_frames, 14, 4)
    np.testing.assert_allclose(np.linalg.norm(q, axis=2), 1.0, atol=1e-12)
    assert (np.sum(q[1:] * q[:-1], axis=2) >= 0).all()


def test_positions_only_stream_has_no_quaternions(cmu86):
    rec = Recording(cmu86.fps, cmu86.skeleton, cmu86.positions[:10], None, "live")
    with pytest.raises(SkeletonError, match="positions only"):
        quaternion_features(rec)


angles3 = arrays(np.float64, (20, 3), elements=st.floats(-np.pi, np.pi))


@settings(max_examples=50, deadline=None)
@given(angles3)
def test_quaternion_matches_matrix(angles):
    m = euler_to_matrix(angles, "zyx")
    q = matrix_to_quaternion(m)
    w, x, y, z = q.T
    # rebuild the matrix from the quaternion (textbook formula)
    back = np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=1,
    )
    np.testing.assert_allclose(back, m, atol=1e-10)


@settings(max_examples=50, deadline=None)
@given(arrays(np.float64, (30, 2, 4), elements=st.floats(-1, 1)), arrays(np.bool_, (30, 2)))
def test_hemisphere_alignment_removes_flips(q, flip):
    q = q / np.maximum(np.linalg.norm(q, axis=2, keepdims=True), 1e-9)
    q[np.linalg.norm(q, axis=2) < 0.5] = [1, 0, 0, 0]
    signed = np.where(flip[..., None], -q, q)
    out = continuous_hemisphere(signed)
    assert (np.sum(out[1:] * out[:-1], axis=2) >= -1e-12).all()
    # only signs changed: each output is +/- its input
    assert np.allclose(np.abs(np.sum(out * signed, axis=2)), np.sum(signed * signed, axis=2))


def test_bone_angle_kernel_equals_naive_twin(cmu86):
    from streamseg.skeleton.bones import ANGLES, bone_point_indices
    from tests.naive import naive_bone_angles

    pos = cmu86.positions[:200].copy()
    pos[50, 4] = np.nan  # a dropout
    pos[60, 13] = pos[60, 18]  # a zero-length upper arm (shoulder on elbow)
    points = bone_point_indices(cmu86.skeleton)
    got = bone_angles(pos, cmu86.skeleton, inclinations=False)
    want = naive_bone_angles(pos, points.tolist(), ANGLES)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    np.testing.assert_allclose(got[~np.isnan(got)], want[~np.isnan(want)], atol=1e-12)
    assert np.isnan(got[60]).any()


def test_inclinations_equal_naive_twin(cmu86):
    from streamseg.skeleton.bones import FEATURE_NAMES, bone_point_indices
    from tests.naive import naive_bone_angles, naive_inclinations

    pos = cmu86.positions[:200].copy()
    pos[50, 4] = np.nan  # a dropout
    pos[60, 13] = pos[60, 18]  # a zero-length upper arm
    points = bone_point_indices(cmu86.skeleton).tolist()
    got = bone_angles(pos, cmu86.skeleton, inclinations=True)
    assert got.shape == (200, 17) == (200, len(FEATURE_NAMES))
    from streamseg.skeleton.bones import ANGLES

    want = np.concatenate(
        [naive_bone_angles(pos, points, ANGLES), naive_inclinations(pos, points, (0.0, 1.0, 0.0))],
        axis=1,
    )
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    np.testing.assert_allclose(got[~np.isnan(got)], want[~np.isnan(want)], atol=1e-12)
    # the first 8 columns are the paper's angles, unchanged
    np.testing.assert_array_equal(got[:, :8], bone_angles(pos, cmu86.skeleton, inclinations=False))
    # hand-derived: a horizontal spine is pi/2 from up; a shin pointing down and forward at
    # 45 degrees is 3 pi / 4; a forearm pointing straight up is 0
    one = cmu86.positions[:1].copy()
    (pelvis, spine), (knee, ankle), (elbow, wrist) = points[0], points[6], points[2]
    one[0, spine] = one[0, pelvis] + (0.2, 0.0, 0.0)
    one[0, ankle] = one[0, knee] + (0.0, -0.3, 0.3)
    one[0, wrist] = one[0, elbow] + (0.0, 0.25, 0.0)
    f = bone_angles(one, cmu86.skeleton, inclinations=True)[0]
    np.testing.assert_allclose(f[[8, 14, 10]], [np.pi / 2, 3 * np.pi / 4, 0.0], atol=1e-7)


def test_inclinations_follow_the_declared_up_axis(cmu86):
    """A Z-up copy of the recording declared up="z" gives the same features; a turn about
    the vertical changes nothing (heading invariance); the wrong up axis does change them."""
    from dataclasses import replace

    pos = cmu86.positions[:300]
    ref = bone_angles(pos, cmu86.skeleton, inclinations=True)
    x, y, z = pos[..., 0], pos[..., 1], pos[..., 2]
    z_up = np.stack([x, -z, y], axis=-1)  # rotation about x: +y -> +z
    skel_z = replace(cmu86.skeleton, up="z")
    np.testing.assert_allclose(bone_angles(z_up, skel_z, inclinations=True), ref, atol=1e-9)
    np.testing.assert_allclose(
        bone_angles(z_up, cmu86.skeleton, inclinations=True, up="z"), ref, atol=1e-9
    )
    c, s = np.cos(1.1), np.sin(1.1)
    turned = np.stack([c * x + s * z, y, -s * x + c * z], axis=-1)
    np.testing.assert_allclose(
        bone_angles(turned, cmu86.skeleton, inclinations=True), ref, atol=1e-9
    )
    assert not np.allclose(bone_angles(z_up, cmu86.skeleton, inclinations=True), ref)
    with pytest.raises(ValueError, match="up='w'"):
        bone_angles(pos, cmu86.skeleton, inclinations=True, up="w")
    # angles_at takes a name or any nonzero vector (normalized), nothing else
    from streamseg.skeleton.bones import angles_at, bone_point_indices

    points = bone_point_indices(cmu86.skeleton)
    for up in ("y", (0.0, 2.5, 0.0), np.array([0.0, 1.0, 0.0])):
        np.testing.assert_allclose(angles_at(pos, points, up), ref, atol=1e-12)
    for bad in ((1.0,), (0.0, 0.0, 0.0), (np.nan, 1.0, 0.0), "w"):
        with pytest.raises(ValueError, match="up="):
            angles_at(pos, points, bad)
    # a body standing along z in a frame declared y-up is noticed; upright or unclear is not
    from streamseg.skeleton.bones import likely_up, spine_directions

    spine_y, n = spine_directions(pos, points)
    assert n == 300 and likely_up(spine_y, "y") is None
    assert likely_up(spine_directions(z_up, points)[0], "y") == "z"
    assert likely_up(spine_directions(z_up, points)[0], "z") is None
    assert likely_up(np.array([1.0, 1.0, 0.0]), "z") is None  # 45 degrees: no clear axis
    assert likely_up(np.zeros(3), "y") is None
    # the body-frame features read the skeleton's up axis too
    np.testing.assert_allclose(
        body_features(z_up, skel_z), body_features(pos, cmu86.skeleton), atol=1e-9
    )
    with pytest.raises(ValueError, match="up="):
        replace(cmu86.skeleton, up="up")
