"""The repetition counter's input: one heading-free pose vector a frame (the 8 bones'
directions in the torso frame, the trunk's direction, the pelvis height over the body's size:
:func:`streamseg._kernels.rep_track.pose_features`). A counter fed these rows counts as one
fed the joint positions."""

from __future__ import annotations

import numpy as np

from streamseg._kernels import frames_in
from streamseg._kernels import rep_track as K

__all__ = ["ROM_JOINTS", "body_scale", "joint_ranges", "pose_features", "stream_features"]

#: Joints whose range of motion a repetition reports: (name, bone, second bone or -1 for the
#: trunk's downward axis), bones as rows of ``rep_track.BONES`` (their directions in the
#: torso frame are the first 24 pose features): the elbows and knees bend between their two
#: bones, the shoulders and hips lift their bone from along the trunk.
ROM_JOINTS = (
    ("l_shoulder", 0, -1),
    ("l_elbow", 0, 1),
    ("r_shoulder", 2, -1),
    ("r_elbow", 2, 3),
    ("l_hip", 4, -1),
    ("l_knee", 4, 5),
    ("r_hip", 6, -1),
    ("r_knee", 6, 7),
)


OWN = np.arange(len(K.POINTS), dtype=np.int64)  # joint indices of frames holding POINTS


def joint_ranges(Z, which=None) -> np.ndarray:
    """Range of motion (degrees) of each of :data:`ROM_JOINTS` (or of those at indices
    ``which``) over pose rows ``Z`` (n, 28), shape (8,) (or (len(which),))."""

    def unit(b):
        v = Z[:, 3 * b : 3 * b + 3]
        n = np.sqrt(np.einsum("ij,ij->i", v, v))[:, None]
        return np.divide(v, n, out=np.zeros_like(v), where=n > 1e-9)

    rows = range(len(ROM_JOINTS)) if which is None else which
    out = np.zeros(len(rows))
    for k, i in enumerate(rows):
        _, a, b = ROM_JOINTS[i]
        u = unit(a)
        # against the trunk's downward axis (0, -1, 0) of the torso frame, or the next bone
        cos = -u[:, 1] if b < 0 else np.einsum("ij,ij->i", u, unit(b))
        ang = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
        out[k] = float(ang.max() - ang.min()) if ang.size else 0.0
    return out


def stream_features(recording, fps=None) -> np.ndarray:
    """The pose features a counter computes for ``recording``'s frames (its body size from
    the first 0.25 s, as live): a counter built without a skeleton on them counts the same."""
    fps = float(recording.fps if fps is None else fps)
    init = max(2, int(round(0.25 * fps)))
    from streamseg.online.rep_bridge import PoseBridge, bridge_frames
    from streamseg.skeleton.names import POINTS, resolve

    P = np.asarray(recording.positions, dtype=np.float64)
    idx = np.asarray(resolve(list(recording.skeleton.names), K.POINTS, POINTS), dtype=np.int64)
    # lost joints bridged as the counter bridges them
    bridge = PoseBridge(len(K.POINTS), bridge_frames(fps), range(4))
    P = np.concatenate([bridge.push(P[:, idx])[0], bridge.finish()[0]])
    if P.shape[0] < recording.positions.shape[0]:  # no frame with a trunk: no pose
        return np.zeros((recording.positions.shape[0], K.N_FEATURES))
    return pose_features(P, K.POINTS, recording.skeleton.up, scale=body_scale(P[:init], OWN))


def pose_features(positions, names, up="y", scale=None):
    """The counter's pose vector of every frame (before the low-pass).

    Parameters
    ----------
    positions : ndarray, shape (n, n_joints, 3)
    names : sequence of str
        Joint names (any skeleton :func:`streamseg.skeleton.names.resolve` maps).
    up : str
        World up axis (``Skeleton.up``).
    scale : float, optional
        Body size (thigh length, positions' units); default: from these frames.

    Returns
    -------
    ndarray, shape (n, 28)
        See :func:`streamseg._kernels.rep_track.pose_features`.
    """
    from streamseg.skeleton.bones import up_vector
    from streamseg.skeleton.names import POINTS, resolve

    P = frames_in(positions)
    idx = np.asarray(resolve(list(names), K.POINTS, POINTS), dtype=np.int64)
    if scale is None:
        scale = body_scale(P, idx)
    out = np.empty((P.shape[0], K.N_FEATURES))
    K.pose_features(P, idx, K.BONES, np.asarray(up_vector(up), dtype=np.float64), float(scale), out)
    return out


def body_scale(P, idx) -> float:
    """Median thigh length over frames ``P``; 1.0 when undefined."""
    th = np.concatenate(
        [
            np.linalg.norm(P[:, idx[10]] - P[:, idx[2]], axis=1),
            np.linalg.norm(P[:, idx[12]] - P[:, idx[3]], axis=1),
        ]
    )
    th = th[np.isfinite(th) & (th > 0)]
    return float(np.median(th)) if th.size else 1.0
