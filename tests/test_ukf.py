"""The UKF and the kinematic model of Wang et al. 2015, section 3 (issue 6)."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg.config import RepetitionConfig
from streamseg.exceptions import ParameterError, SkeletonError
from streamseg.kinematics.model import (
    N_ANGLES,
    bone_directions,
    fit_angles,
    forward_kinematics,
)
from streamseg.kinematics.ukf import ukf_pass, ukf_update
from streamseg.offline.repetition import angles_from_positions

# ASF bone whose END is each model point: the synthetic skeletons below use Acclaim names.
ASF_JOINTS = {
    "pelvis": "root", "sternum": "thorax",
    "l_shoulder": "lclavicle", "l_elbow": "lhumerus", "l_wrist": "lradius",
    "r_shoulder": "rclavicle", "r_elbow": "rhumerus", "r_wrist": "rradius",
    "l_hip": "lhipjoint", "l_knee": "lfemur", "l_ankle": "ltibia",
    "r_hip": "rhipjoint", "r_knee": "rfemur", "r_ankle": "rtibia",
}

LENGTHS = np.array([0.45, 1.0, 0.85] * 2 + [0.3, 1.3, 1.2] * 2)
PDIR = np.array([0.5, -0.7, 0.3]) / np.linalg.norm([0.5, -0.7, 0.3])


def true_angles(n, fps):
    """Smooth periodic joint angles away from the model's Euler singularities."""
    t = np.arange(n) / fps
    base = np.array([0.1, 0.05, 0.3, 0.2, 0.4, 0.8] * 2 + [0.2, 0.1, 0.1, 0.5] * 2)
    k = np.arange(N_ANGLES)
    return base + 0.35 * np.sin(2 * np.pi * 0.5 * t[:, None] + k[None, :])


def test_ukf_update_is_the_kalman_update_for_a_linear_measurement():
    rng = np.random.default_rng(0)
    d, m = 4, 3
    H = rng.normal(size=(m, d))
    A = rng.normal(size=(d, d))
    P = A @ A.T + np.eye(d)
    x = rng.normal(size=d)
    R = np.array([0.5, 0.2, 0.1])
    y = rng.normal(size=m)
    x1, P1 = ukf_update(x, P, y, lambda X: X @ H.T, R)
    S = H @ P @ H.T + np.diag(R)
    K = P @ H.T @ np.linalg.inv(S)
    np.testing.assert_allclose(x1, x + K @ (y - H @ x), rtol=1e-10)
    np.testing.assert_allclose(P1, P - K @ S @ K.T, rtol=1e-9, atol=1e-12)


def test_ukf_update_ignores_missing_measurements():
    P = np.eye(2)
    x = np.zeros(2)

    def h(X):
        return X

    x1, P1 = ukf_update(x, P, np.array([1.0, np.nan]), h, np.array([1.0, 1.0]))
    assert x1[0] == pytest.approx(0.5) and x1[1] == 0.0
    assert P1[1, 1] == pytest.approx(1.0)


def test_ukf_pass_variance_cap_keeps_unobserved_state_bounded():
    Y = np.zeros((200, 1))

    def h(X):
        return X[:, :1]  # the second component is never observed

    _, _, P = ukf_pass(Y, h, np.zeros(2), np.eye(2) * 0.01, np.array([1e-3, 1e-2]),
                       np.array([1e-2]), max_std=np.array([np.inf, 0.3]))
    assert np.sqrt(P[1, 1]) <= 0.3 + 1e-12
    with pytest.raises(ParameterError):
        ukf_pass(np.zeros(5), h, np.zeros(2), np.eye(2), np.ones(2), np.ones(1))


def test_four_pass_round_trip_recovers_angles_and_lengths():
    fps, n = 60.0, 300
    A = true_angles(n, fps)
    Y = forward_kinematics(A, LENGTHS, PDIR)
    est, lengths = fit_angles(Y, fps, PDIR, LENGTHS * 1.05, position_noise=0.01)
    err = np.abs(est - A)
    assert np.percentile(err, 95) < 0.02  # rad, on every angle of every limb
    np.testing.assert_allclose(lengths, LENGTHS, atol=0.02)
    np.testing.assert_allclose(forward_kinematics(est, lengths, PDIR), Y, atol=0.02)


def _world_positions(A, lengths):
    """Posed ASF-named joints for model angles (torso frame = world frame)."""
    Y = forward_kinematics(A, lengths, PDIR).reshape(-1, 12, 3)
    n = A.shape[0]
    mirror = np.array([-1.0, 1.0, 1.0])
    sternum = np.tile([0.0, 1.5, 0.0], (n, 1))
    pts = {"pelvis": np.zeros((n, 3)), "sternum": sternum}
    arm_keys = ("shoulder", "elbow", "wrist")
    leg_keys = ("hip", "knee", "ankle")
    for i, k in enumerate(arm_keys):
        pts["l_" + k] = sternum + Y[:, i]
        pts["r_" + k] = sternum + Y[:, 3 + i] * mirror
    for i, k in enumerate(leg_keys):
        pts["l_" + k] = Y[:, 6 + i]
        pts["r_" + k] = Y[:, 9 + i] * mirror
    names = list(ASF_JOINTS.values()) + ["head"]
    P = np.zeros((n, len(names), 3))
    for key, bone in ASF_JOINTS.items():
        P[:, names.index(bone)] = pts[key]
    return P, names


def test_positions_from_known_angles_come_back_through_the_whole_front_end():
    fps, n = 60.0, 240
    A = true_angles(n, fps)
    P, names = _world_positions(A, LENGTHS * 0.3)  # any unit: 0.3 m per "long bone"
    # A random-walk step nearer this slow motion (<= 1.1 rad/s) than the default (8 rad/s,
    # chosen for fast arm circles), with which near-straight knees trade hip twist for
    # flexion by up to ~0.2 rad at 60 Hz.
    est = angles_from_positions(P, names, fps, RepetitionConfig(angle_speed=4.0))
    assert np.percentile(np.abs(est - A), 95) < 0.02
    with pytest.raises(SkeletonError, match="lradius"):
        angles_from_positions(P[:, 1:], names[1:] if names[0] != "lradius" else names, fps)


def _roughness(x):
    return float(np.mean(np.diff(x, 2, axis=0) ** 2))


@pytest.mark.parametrize("seed", [1, 2])
def test_with_centimetres_of_noise_ukf_angles_are_smoother_and_closer_than_direct_ones(seed):
    fps, n = 30.0, 300
    rng = np.random.default_rng(seed)
    A = true_angles(n, fps)
    scale = 0.3  # metres per body-scale unit
    P, names = _world_positions(A, LENGTHS * scale)
    noisy = P + rng.normal(0.0, 0.025, P.shape)  # 2.5 cm, Kinect-like
    # Filter settings matched to the simulation: 2.5 cm is ~0.08 of the 0.32 m body scale,
    # and the true angles move at most 1.1 rad/s.
    cfg = RepetitionConfig(position_noise=0.08, angle_speed=2.0)
    est = angles_from_positions(noisy, names, fps, cfg)
    # Direct elbow and knee angles from the noisy positions (frame-invariant hinge angles).
    idx = {b: names.index(b) for b in ASF_JOINTS.values()}

    def hinge(a, b, c):
        u = noisy[:, idx[b]] - noisy[:, idx[a]]
        v = noisy[:, idx[c]] - noisy[:, idx[b]]
        cos = np.sum(u * v, axis=1) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1)
        return np.arccos(np.clip(cos, -1, 1))

    direct = {5: hinge("lclavicle", "lhumerus", "lradius"),
              11: hinge("rclavicle", "rhumerus", "rradius"),
              15: hinge("lhipjoint", "lfemur", "ltibia"),
              19: hinge("rhipjoint", "rfemur", "rtibia")}
    for col, d in direct.items():
        assert _roughness(est[:, col]) < 0.2 * _roughness(d), col
        assert np.mean(np.abs(est[:, col] - A[:, col])) < np.mean(np.abs(d - A[:, col])), col


def test_bone_directions_are_unit_vectors_and_ignore_equivalent_euler_triples():
    A = true_angles(50, 30.0)
    D = bone_directions(A).reshape(50, 10, 3)
    np.testing.assert_allclose(np.linalg.norm(D, axis=2), 1.0, atol=1e-12)
    # Shoulder (x, z, y-twist) and (x + pi, pi - z, y + pi) are the same rotation.
    B = A.copy()
    B[:, 2] += np.pi
    B[:, 4] = np.pi - B[:, 4]
    B[:, 3] += np.pi
    np.testing.assert_allclose(bone_directions(B), bone_directions(A), atol=1e-12)


def test_kinect_named_skeleton_gives_the_same_angles():
    """The joint-name map lets a Kinect v2 skeleton reach the same model points."""
    kinect = {"root": "SpineBase", "thorax": "SpineShoulder", "lclavicle": "ShoulderLeft",
              "lhumerus": "ElbowLeft", "lradius": "WristLeft", "rclavicle": "ShoulderRight",
              "rhumerus": "ElbowRight", "rradius": "WristRight", "lhipjoint": "HipLeft",
              "lfemur": "KneeLeft", "ltibia": "AnkleLeft", "rhipjoint": "HipRight",
              "rfemur": "KneeRight", "rtibia": "AnkleRight", "head": "Head"}
    fps, n = 60.0, 120
    P, names = _world_positions(true_angles(n, fps), LENGTHS * 0.3)
    cfg = RepetitionConfig(angle_speed=4.0)
    np.testing.assert_array_equal(angles_from_positions(P, names, fps, cfg),
                                  angles_from_positions(P, [kinect[j] for j in names], fps, cfg))
