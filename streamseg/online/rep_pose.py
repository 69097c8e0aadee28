"""The repetition counter's input: one heading-free pose vector a frame (the 8 bones'
directions in the torso frame, the trunk's direction, the pelvis height over the body's size:
:func:`streamseg._kernels.rep_track.pose_features`). A counter fed these rows counts as one
fed the joint positions."""

from __future__ import annotations

import numpy as np

from streamseg._kernels import frames_in
from streamseg._kernels import rep_track as K

__all__ = ["body_scale", "pose_features", "stream_features"]


def stream_features(recording, fps=None) -> np.ndarray:
    """The pose features a counter computes for ``recording``'s frames (its body size from
    the first 0.25 s, as live): a counter built without a skeleton on them counts the same."""
    fps = float(recording.fps if fps is None else fps)
    init = max(2, int(round(0.25 * fps)))
    from streamseg.skeleton.names import POINTS, resolve

    P = np.ascontiguousarray(recording.positions, dtype=np.float64)
    idx = np.asarray(resolve(list(recording.skeleton.names), K.POINTS, POINTS), dtype=np.int64)
    return pose_features(P, recording.skeleton.names, recording.skeleton.up,
                         scale=body_scale(P[:init], idx))


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
    K.pose_features(P, idx, K.BONES, np.asarray(up_vector(up), dtype=np.float64), float(scale),
                    out)
    return out


def body_scale(P, idx) -> float:
    """Median thigh length over frames ``P``; 1.0 when undefined."""
    th = np.concatenate([np.linalg.norm(P[:, idx[10]] - P[:, idx[2]], axis=1),
                         np.linalg.norm(P[:, idx[12]] - P[:, idx[3]], axis=1)])
    th = th[np.isfinite(th) & (th > 0)]
    return float(np.median(th)) if th.size else 1.0
