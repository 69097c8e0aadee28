"""Exercise labels of repetition sets: the action labels ``segment --method aca`` gives.

The sets themselves come from the counter (:mod:`streamseg.online.repetition`: a loop unlike
the last, a pause or the end of repeating ends a set), offline and live alike; the action
labels only name them. Offline they are HACA's on the whole take (the number of actions
found, as ``segment --method aca``); live the newest relabel's (``streamseg.online.rep_sets``).
A set's label is the commonest label of its repetitions' middle frames.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from streamseg.config import ACAConfig

__all__ = ["action_labels", "label_sets"]


def action_labels(recording, aca_config: ACAConfig | None = None) -> np.ndarray:
    """HACA's action label of every frame of ``recording``.

    On the 14-joint quaternion features when the recording carries joint rotations, on the
    body's bone directions (:func:`streamseg.skeleton.body_features`) otherwise.

    Returns
    -------
    ndarray of int64, shape (n_frames,)
    """
    from streamseg.offline.model_selection import fit_aca
    from streamseg.skeleton import body_features, quaternion_features

    if getattr(recording, "rotations", None) is not None:
        X = quaternion_features(recording)
    else:
        X = body_features(recording.positions, recording.skeleton)
    model = fit_aca(X, aca_config or ACAConfig(), float(recording.fps))
    out = np.zeros(recording.positions.shape[0], dtype=np.int64)
    for s, e, lab in model.segments_:
        out[s:e] = lab
    return out


def label_sets(frame_labels, sets) -> list:
    """The label of each set: the commonest of its repetitions' middle frames.

    Parameters
    ----------
    frame_labels : ndarray of int, shape (n_frames,)
    sets : list of dict
        With ``repetitions`` [(start, end), ...] (:func:`streamseg.offline.repetition.
        set_summary`).

    Returns
    -------
    list of int
    """
    out = []
    for st in sets:
        mids = [
            frame_labels[min((a + b) // 2, len(frame_labels) - 1)] for a, b in st["repetitions"]
        ]
        out.append(int(Counter(int(m) for m in mids).most_common(1)[0][0]))
    return out
