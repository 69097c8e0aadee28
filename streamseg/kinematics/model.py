"""Full-body kinematic model of Wang et al. 2015, section 3, and its four-pass UKF fit.

Per side, a 6-DoF arm (2 scapula angles, 3 shoulder, 1 elbow; clavicle, humerus and radius
lengths) and a 4-DoF leg (3 hip angles, 1 knee; pelvis, femur and tibia lengths). Positions are
expressed in a torso frame (x to the subject's left, y up, z forward) built from the pelvis,
both hips and the sternum, so the angles do not change when the subject turns. The right
limbs are mirrored (x -> -x) onto the left model, so one angle means the same movement on both
sides. Lengths are divided by a body scale (median of the four long bones) so the noise
settings hold for any unit and body size.

Angle layout of the 20 outputs (:data:`ANGLE_NAMES`): left arm, right arm, left leg, right leg.
3-DoF joints rotate about x, then z (swing), then y (twist about the bone): the Euler
singularity is then at the bone pointing sideways-horizontally. Elbow and knee use |angle|.
Joint names: any skeleton the joint-name map :mod:`streamseg.skeleton.names` knows (CMU/HDM05
ASF, CMU-to-BVH conversions, Kinect v2) reaches the model's 14 points (:data:`MODEL_POINTS`).
"""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, sosfiltfilt

from streamseg.exceptions import ParameterError, SkeletonError
from streamseg.kinematics.ukf import ukf_pass
from streamseg.skeleton.names import POINTS, resolve

__all__ = ["ANGLE_NAMES", "MODEL_POINTS", "fit_angles", "forward_kinematics", "limb_points",
           "torso_frames"]

_ARM = ("sca_x", "sca_y", "sho_x", "sho_y", "sho_z", "elb")
_LEG = ("hip_x", "hip_y", "hip_z", "kne")
ANGLE_NAMES = tuple(
    [f"l_{a}" for a in _ARM] + [f"r_{a}" for a in _ARM]
    + [f"l_{a}" for a in _LEG] + [f"r_{a}" for a in _LEG]
)
N_ANGLES = 20
HINGES = [5, 11, 15, 19]  # elbows and knees (1-DoF flexion, >= 0)
N_LENGTHS = 12  # (clavicle, humerus, radius) x 2 arms, (pelvis, femur, tibia) x 2 legs

# The model's points, canonical names of streamseg.skeleton.names.POINTS.
MODEL_POINTS = ("pelvis", "sternum", "l_shoulder", "l_elbow", "l_wrist", "r_shoulder",
                "r_elbow", "r_wrist", "l_hip", "l_knee", "l_ankle", "r_hip", "r_knee", "r_ankle")


def limb_points(positions: np.ndarray, names) -> dict:
    """The 14 model points from posed joint positions.

    Parameters
    ----------
    positions : ndarray, shape (n_frames, n_joints, 3)
    names : sequence of str, length n_joints
        Joint names of any skeleton :func:`streamseg.skeleton.names.resolve` maps.

    Returns
    -------
    dict of str -> ndarray (n_frames, 3)

    Raises
    ------
    SkeletonError
        Listing the model points the skeleton lacks.
    """
    idx = resolve(list(names), MODEL_POINTS, POINTS)
    return {k: positions[:, i] for k, i in zip(MODEL_POINTS, idx)}


def unit(v):
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def torso_frames(pts: dict, fps: float, cutoff_hz: float | None = 2.0):
    """Per-frame torso frame (origin at the pelvis) from pelvis, hips and sternum.

    The four defining points are low-passed first (zero phase) when ``cutoff_hz`` is given,
    because noise on the 20 cm hip baseline would otherwise tilt every angle.

    Returns
    -------
    R : ndarray, shape (n_frames, 3, 3)
        Rows are the torso x (left), y (up), z (forward) axes in world coordinates.
    """
    keys = ("pelvis", "sternum", "l_hip", "r_hip")
    P = {k: np.asarray(pts[k], dtype=np.float64) for k in keys}
    n = P["pelvis"].shape[0]
    if cutoff_hz is not None and n > 30 and cutoff_hz < 0.45 * fps:
        sos = butter(2, cutoff_hz, fs=fps, output="sos")
        P = {k: sosfiltfilt(sos, v, axis=0) for k, v in P.items()}
    up = unit(P["sternum"] - P["pelvis"])
    lat = P["l_hip"] - P["r_hip"]
    lat = unit(lat - np.sum(lat * up, axis=1, keepdims=True) * up)
    fwd = np.cross(lat, up)
    return np.stack([lat, up, fwd], axis=1)


def _rot(axis: int, a: np.ndarray) -> np.ndarray:
    """Rotation matrices about a coordinate axis, shape a.shape + (3, 3)."""
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    i, j = [(1, 2), (0, 2), (0, 1)][axis]
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    sign = -1.0 if axis == 1 else 1.0  # Ry has the sine signs the other way round
    R[..., i, j] = -s * sign
    R[..., j, i] = s * sign
    return R


_DOWN = np.array([0.0, -1.0, 0.0])
_LEFT = np.array([1.0, 0.0, 0.0])


def arm_points(a, lengths):
    """Shoulder, elbow, wrist relative to the sternum (eqs. 1-3). a: (s, 6), lengths: (s, 3)."""
    R_sca = _rot(1, a[:, 1]) @ _rot(2, a[:, 0])
    sho = lengths[:, :1] * (R_sca @ _LEFT)
    # Swing (x then z) before twist (about the bone, y): the Euler singularity is then at the
    # humerus pointing sideways-horizontal, not at 90 degrees of (poorly observed) twist.
    R_hum = R_sca @ _rot(0, a[:, 2]) @ _rot(2, a[:, 4]) @ _rot(1, a[:, 3])
    elb = sho + lengths[:, 1:2] * (R_hum @ _DOWN)
    # Hinges use |angle|: a hyperextended elbow/knee plus a half-turn of twist would
    # otherwise reproduce the same points, and the filter could settle on that mirror branch.
    fore = (R_hum @ _rot(0, -np.abs(a[:, 5]))) @ _DOWN  # flexion brings the forearm forward
    wri = elb + lengths[:, 2:3] * fore
    return sho, elb, wri


def leg_points(a, lengths, pelvis_dir):
    """Hip, knee, ankle relative to the pelvis (eqs. 4-5). a: (s, 4), lengths: (s, 3)."""
    hip = lengths[:, :1] * pelvis_dir
    R = _rot(0, a[:, 0]) @ _rot(2, a[:, 2]) @ _rot(1, a[:, 1])  # swing x, z, then twist y
    kne = hip + lengths[:, 1:2] * (R @ _DOWN)
    ank = kne + lengths[:, 2:3] * ((R @ _rot(0, np.abs(a[:, 3]))) @ _DOWN)
    return hip, kne, ank


def forward_kinematics(angles, lengths, pelvis_dir=(0.5, -0.7, 0.3)):
    """Model points from parameters (the measurement function H of eq. 7).

    Parameters
    ----------
    angles : ndarray, shape (s, 20)
        In :data:`ANGLE_NAMES` order, radians.
    lengths : ndarray, shape (s, 12) or (12,)
        Clavicle, humerus, radius (left, right), then pelvis, femur, tibia (left, right).
    pelvis_dir : array-like, shape (3,)
        Direction from the pelvis centre to the (mirrored) hip joint in the torso frame.

    Returns
    -------
    ndarray, shape (s, 36)
        Left shoulder, elbow, wrist, right ditto (relative to the sternum), then left hip,
        knee, ankle, right ditto (relative to the pelvis), in the mirrored torso frame.
    """
    angles = np.atleast_2d(angles)
    lengths = np.broadcast_to(lengths, (angles.shape[0], N_LENGTHS))
    pdir = unit(np.asarray(pelvis_dir, dtype=np.float64))
    out = [*arm_points(angles[:, 0:6], lengths[:, 0:3]),
           *arm_points(angles[:, 6:12], lengths[:, 3:6]),
           *leg_points(angles[:, 12:16], lengths[:, 6:9], pdir),
           *leg_points(angles[:, 16:20], lengths[:, 9:12], pdir)]
    return np.concatenate(out, axis=1)


SETTLE_STEPS = 20  # updates on frame 0 before pass 1 (pulls the neutral pose onto frame 0)
SETTLE_VAR = 1e-4  # variance re-added per settling step so it keeps moving
_MIRROR = np.array([-1.0, 1.0, 1.0])
_OBS_ORDER = ("l_shoulder", "l_elbow", "l_wrist", "r_shoulder", "r_elbow", "r_wrist",
              "l_hip", "l_knee", "l_ankle", "r_hip", "r_knee", "r_ankle")


def observations(pts: dict, fps: float, torso_cutoff_hz: float | None = 2.0, *,
                 scale: float | None = None, pelvis_dir=None):
    """Measurements in the model's frame, scaled by body size.

    ``scale`` and ``pelvis_dir`` are estimated from ``pts`` unless given (a live stream fixes
    them from its first frames).

    Returns
    -------
    Y : ndarray, shape (n_frames, 36)
    scale : float
        Body scale (median long-bone length) the positions were divided by.
    pelvis_dir : ndarray, shape (3,)
    lengths0 : ndarray, shape (12,)
        Median observed bone lengths (scaled), the first pass's initial lengths.
    """
    R = torso_frames(pts, fps, torso_cutoff_hz)
    local = {}
    for k in _OBS_ORDER:
        base = pts["sternum"] if k[2:] in ("shoulder", "elbow", "wrist") else pts["pelvis"]
        v = np.einsum("nij,nj->ni", R, np.asarray(pts[k], dtype=np.float64) - base)
        local[k] = v * _MIRROR if k.startswith("r_") else v

    def seg(a, b):
        return np.nanmedian(np.linalg.norm(local[b] - (local[a] if a else 0.0), axis=1))

    raw = []
    for s in ("l_", "r_"):
        raw += [seg(None, s + "shoulder"), seg(s + "shoulder", s + "elbow"),
                seg(s + "elbow", s + "wrist")]
    for s in ("l_", "r_"):
        raw += [seg(None, s + "hip"), seg(s + "hip", s + "knee"), seg(s + "knee", s + "ankle")]
    raw = np.array(raw)
    if scale is None:
        scale = float(np.median(raw[[1, 2, 4, 5, 7, 8, 10, 11]]))
    if not np.isfinite(scale) or scale <= 0:
        raise SkeletonError("cannot estimate body size: limb joints coincide or are all missing")
    if pelvis_dir is None:
        hips = np.concatenate([local["l_hip"], local["r_hip"]])
        pelvis_dir = unit(np.nanmedian(unit(hips), axis=0))
    Y = np.concatenate([local[k] for k in _OBS_ORDER], axis=1) / scale
    return Y, scale, pelvis_dir, raw / scale


def fit_angles(Y, fps, pelvis_dir, lengths0, *, position_noise=0.05, angle_speed=4.0,
               length_speed=0.02, passes=4):
    """Four-pass UKF (section 3.2): joint-angle trajectories from scaled observations.

    Passes 1 (forward) and 2 (backward) estimate angles and bone lengths together; passes 3
    (forward) and 4 (backward) fix the lengths to the mean of the first two passes' estimates
    and filter the angles alone. The output is the mean of passes 3 and 4: the forward filter
    lags and the backward one leads by about the same amount, so their mean is centred.

    The four limbs share no parameter and no observation, so the full-body filter factorises
    exactly into one filter per limb (state 9 for an arm, 7 for a leg); small states keep the
    sigma points (at +-sqrt(d) standard deviations) in the region where the model is smooth.
    Lengths are filtered as logarithms so they stay positive.

    Parameters
    ----------
    Y : ndarray, shape (n_frames, 36)
        From :func:`observations`.
    fps : float
    pelvis_dir, lengths0 : ndarray, shapes (3,), (12,)
        From :func:`observations`.
    position_noise : float
        Measurement noise standard deviation, in body-scale units (1 = one long bone).
    angle_speed : float
        Random-walk standard deviation of each angle per second of motion, rad/s (the
        per-frame step is ``angle_speed / fps``).
    length_speed : float
        Same for log bone lengths in passes 1-2, per second.
    passes : {2, 4}
        4 as in the paper; 2 stops after the first forward/backward pair.

    Returns
    -------
    angles : ndarray, shape (n_frames, 20)
    lengths : ndarray, shape (12,)
        Fixed bone lengths used in passes 3-4 (body-scale units).
    """
    Y = np.asarray(Y, dtype=np.float64)
    if Y.ndim != 2 or Y.shape[1] != 36 or Y.shape[0] < 2:
        raise ParameterError(f"Y must have shape (n_frames >= 2, 36); got {Y.shape}")
    if passes not in (2, 4):
        raise ParameterError(f"passes={passes!r} is invalid: expected 2 or 4")
    lengths0 = np.asarray(lengths0, dtype=np.float64)
    if lengths0.shape != (N_LENGTHS,) or not np.all(lengths0 > 0):
        raise ParameterError(f"lengths0 must be {N_LENGTHS} positive lengths; got {lengths0}")
    pdir = unit(np.asarray(pelvis_dir, dtype=np.float64))
    angles = np.empty((Y.shape[0], N_ANGLES))
    lengths = np.empty(N_LENGTHS)
    a0 = initial_angles()
    for limb, (asl, lsl, ysl) in enumerate(LIMBS):
        if limb < 2:
            def chain(A, L):
                return np.concatenate(arm_points(A, L), axis=1)
        else:
            def chain(A, L):
                return np.concatenate(leg_points(A, L, pdir), axis=1)
        angles[:, asl], lengths[lsl] = _fit_limb(
            Y[:, ysl], chain, a0[asl], lengths0[lsl], fps, position_noise, angle_speed,
            length_speed, passes)
    angles[:, HINGES] = np.abs(angles[:, HINGES])  # the model uses |hinge angle|
    return angles, lengths


# (angle slice, length slice, observation slice) per limb: left arm, right arm, legs
LIMBS = ((slice(0, 6), slice(0, 3), slice(0, 9)), (slice(6, 12), slice(3, 6), slice(9, 18)),
          (slice(12, 16), slice(6, 9), slice(18, 27)),
          (slice(16, 20), slice(9, 12), slice(27, 36)))
_MAX_ANGLE_STD = 0.3  # rad; caps the variance of angles the data leave unobserved (see below)
INITIAL_ANGLE_STD = 0.3  # rad
INITIAL_LOG_LENGTH_STD = 0.05


def _fit_limb(Y, chain, a0, l0, fps, noise, angle_speed, length_speed, passes):
    """Four passes over one limb. Returns angles (n, k) and the fixed lengths (3,)."""
    k = a0.shape[0]
    R = np.full(Y.shape[1], noise**2)
    qa = (angle_speed / fps) ** 2
    ql = (length_speed / fps) ** 2

    def h_full(X):
        return chain(X[:, :k], np.exp(X[:, k:]))

    x = np.concatenate([a0, np.log(l0)])
    P = np.diag(np.concatenate([np.full(k, INITIAL_ANGLE_STD**2),
                                np.full(3, INITIAL_LOG_LENGTH_STD**2)]))
    Q = np.concatenate([np.full(k, qa), np.full(3, ql)])
    # Settle on the first frame before pass 1 so pass 1 does not start with a transient.
    first = Y[:1]
    for _ in range(SETTLE_STEPS):
        _, x, P = ukf_pass(first, h_full, x, P, np.full(k + 3, SETTLE_VAR), R,
                           max_std=std_caps(k, 3))
    X1, x, P = ukf_pass(Y, h_full, x, P, Q, R, max_std=std_caps(k, 3))
    X2, x, P = ukf_pass(Y, h_full, x, P, Q, R, reverse=True, max_std=std_caps(k, 3))
    if passes == 2:
        return 0.5 * (X1[:, :k] + X2[:, :k]), np.exp(0.5 * (X1[-1, k:] + X2[0, k:]))
    lengths = 0.5 * (np.exp(X1[:, k:]).mean(axis=0) + np.exp(X2[:, k:]).mean(axis=0))

    def h_angles(A):
        return chain(A, np.broadcast_to(lengths, (A.shape[0], 3)))

    Qa = np.full(k, qa)
    X3, a, Pa = ukf_pass(Y, h_angles, x[:k], P[:k, :k], Qa, R, max_std=std_caps(k, 0))
    X4, _, _ = ukf_pass(Y, h_angles, a, Pa, Qa, R, reverse=True, max_std=std_caps(k, 0))
    return 0.5 * (X3 + X4), lengths


def std_caps(k, n_lengths):
    # Angles the data do not constrain (e.g. upper-arm twist while the elbow is straight)
    # would random-walk to variances whose sigma points wrap around the circle; capping them
    # keeps the filter local. Log lengths are never capped (their variance stays small).
    return np.concatenate([np.full(k, _MAX_ANGLE_STD), np.full(n_lengths, np.inf)])


def initial_angles():
    """A neutral pose: clavicles level, arms and legs hanging, elbows and knees slightly bent.

    The slight bend picks the anatomical branch of the elbow/knee solution from the start.
    """
    a = np.zeros(N_ANGLES)
    a[5] = a[11] = 0.2
    a[15] = a[19] = 0.2
    return a


_ARM_BONES = ("clavicle", "humerus", "radius")
_LEG_BONES = ("femur", "tibia")
BONE_NAMES = tuple(f"{s}_{b}_{c}" for s, bones in
                   (("l", _ARM_BONES), ("r", _ARM_BONES), ("l", _LEG_BONES), ("r", _LEG_BONES))
                   for b in bones for c in "xyz")


def bone_directions(angles):
    """Unit direction of each model bone in the (mirrored) torso frame.

    Functions of the angles that every equivalent Euler triple maps to the same value, so they
    stay continuous where the 3-DoF shoulder jumps between Euler branches (full arm circles).

    Parameters
    ----------
    angles : ndarray, shape (n_frames, 20)

    Returns
    -------
    ndarray, shape (n_frames, 30)
        Clavicle, humerus, radius (left then right arm), femur, tibia (left then right leg),
        x/y/z each; names in :data:`BONE_NAMES`.
    """
    P = forward_kinematics(angles, np.ones(N_LENGTHS), (1.0, 0.0, 0.0)).reshape(-1, 12, 3)
    arm_l = [P[:, 0], P[:, 1] - P[:, 0], P[:, 2] - P[:, 1]]
    arm_r = [P[:, 3], P[:, 4] - P[:, 3], P[:, 5] - P[:, 4]]
    leg_l = [P[:, 7] - P[:, 6], P[:, 8] - P[:, 7]]
    leg_r = [P[:, 10] - P[:, 9], P[:, 11] - P[:, 10]]
    return np.concatenate(arm_l + arm_r + leg_l + leg_r, axis=1)


def estimate_noise(positions: np.ndarray, scale: float) -> float:
    """Position noise std (body-scale units) from the frame-to-frame jitter of all joints.

    White noise of std s gives second differences of std ``s * sqrt(6)``; smooth motion adds
    little to them at 30 Hz or more except on fast extremities, so the median over joints
    and axes of a robust (MAD) std is taken.

    Parameters
    ----------
    positions : ndarray, shape (n_frames, n_joints, 3)
    scale : float
        Body scale the result is divided by.

    Returns
    -------
    float
    """
    P = np.asarray(positions, dtype=np.float64)
    if P.shape[0] < 4:
        return 0.0
    d2 = np.diff(P, 2, axis=0).reshape(P.shape[0] - 2, -1)
    mad = np.nanmedian(np.abs(d2 - np.nanmedian(d2, axis=0)), axis=0) / 0.6745
    return float(np.nanmedian(mad) / np.sqrt(6.0) / scale)
