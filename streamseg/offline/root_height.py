"""The root (pelvis) height as an analysed parameter of the repetition segmenter
(``RepetitionConfig.root_height_weight``, off by default)."""

from __future__ import annotations

import numpy as np

from streamseg.config import RepetitionConfig
from streamseg.kinematics.model import limb_points, observations
from streamseg.skeleton.bones import up_vector

__all__ = ["root_height", "with_root_height"]


def root_height(positions, names, fps, up="y", config: RepetitionConfig | None = None):
    """The pelvis height per frame, relative to its median over the take, in body-scale units.

    The bone directions carry no height: a bounce before a hop and a second hop look alike
    in them, the hip rising 7-13 cm in the one and 19-30 cm in the other (HDM05 dg).

    Parameters
    ----------
    positions : ndarray, shape (n_frames, n_joints, 3)
    names : sequence of str
        Joint names (any skeleton :func:`streamseg.kinematics.model.limb_points` maps).
    fps : float
    up : str
        World up axis of the positions (``Skeleton.up``: ``"y"``, ``"-z"``, ...).
    config : RepetitionConfig, optional
        Its ``torso_cutoff_hz`` enters the body scale's estimate (as in the UKF's).

    Returns
    -------
    ndarray, shape (n_frames,)
        Height along ``up`` minus its median, divided by the body scale (the median long-bone
        length, :func:`streamseg.kinematics.model.observations`; about 0.4 m on an adult).
    """
    cfg = config or RepetitionConfig()
    pts = limb_points(np.asarray(positions, dtype=np.float64), names)
    scale = observations(pts, fps, cfg.torso_cutoff_hz)[1]
    h = pts["pelvis"] @ up_vector(up)
    return (h - np.nanmedian(h)) / scale


def with_root_height(D, recording, config: RepetitionConfig | None = None):
    """The analysed parameters: ``D`` and, with ``root_height_weight > 0``, the root height.

    Parameters
    ----------
    D : ndarray, shape (n_frames, n_params)
        The bone directions of ``recording`` (:func:`streamseg.kinematics.model.
        bone_directions` of the UKF angles).
    recording : Recording
        Joint positions, names, frame rate and up axis.
    config : RepetitionConfig, optional

    Returns
    -------
    ndarray, shape (n_frames, n_params) or (n_frames, n_params + 1)
        ``D`` unchanged when ``root_height_weight`` is 0, else with the last column
        ``root_height_weight`` x :func:`root_height`.
    """
    cfg = config or RepetitionConfig()
    if cfg.root_height_weight <= 0:
        return D
    h = root_height(recording.positions, recording.skeleton.names, recording.fps,
                    recording.skeleton.up, cfg)
    return np.concatenate([D, cfg.root_height_weight * h[:, None]], axis=1)
