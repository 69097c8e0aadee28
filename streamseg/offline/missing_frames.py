"""Frames with missing joints (NaN positions: marker dropout) bridged for the repetition model.

The cut detector skips a frame with any NaN angle (:mod:`streamseg.offline.lof`); the
repetition counter needs evenly spaced frames (a causal low-pass, decimation), so a frame
with any NaN joint position is skipped by bridging it: its positions are interpolated
linearly, per coordinate, between the nearest good frames before and after it (held at the
take's ends), and its rotations are those of the nearest good frame. No observation of the
bad frame is used; the frame indices stay those of the file.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

__all__ = ["bad_frames", "bridge_missing_frames", "bridge_rows"]


def bad_frames(positions) -> np.ndarray:
    """Whether each frame has a NaN or infinite joint coordinate, shape (n_frames,)."""
    P = np.asarray(positions)
    return ~np.isfinite(P.reshape(P.shape[0], int(np.prod(P.shape[1:])))).all(axis=1)


def bridge_rows(A, bad) -> np.ndarray:
    """A float64 copy of ``A`` (shape (n_frames, ...)) with the ``bad`` rows interpolated
    linearly per column between the nearest good rows (held at the ends); needs a good row."""
    good = np.flatnonzero(~bad)
    idx = np.flatnonzero(bad)
    out = np.array(A, dtype=np.float64)
    flat = out.reshape(out.shape[0], -1)
    for c in range(flat.shape[1]):
        flat[idx, c] = np.interp(idx, good, flat[good, c])
    return out


def bridge_missing_frames(recording, ignore=()):
    """``(recording, n_bad)``: ``recording`` with its bad frames bridged, and how many.

    Parameters
    ----------
    recording : Recording
        Positions shape (n_frames, n_joints, 3).
    ignore : sequence of str
        Joints whose NaN make no frame bad (lost for good: they stay NaN).

    Returns
    -------
    Recording
        The same object when no frame is bad or every frame is (nothing to bridge from).
    int
        Frames with a NaN or infinite joint coordinate.
    """
    P = recording.positions
    if len(ignore):
        keep = [j for j, name in enumerate(recording.skeleton.names) if name not in ignore]
        P = P[:, keep]
    bad = bad_frames(P)
    n_bad = int(bad.sum())
    if n_bad == 0 or n_bad == bad.size:
        return recording, n_bad
    good = np.flatnonzero(~bad)
    idx = np.flatnonzero(bad)
    out = replace(recording, positions=bridge_rows(recording.positions, bad))
    if recording.rotations is not None:
        R = np.array(recording.rotations)
        pos = np.clip(np.searchsorted(good, idx), 1, good.size - 1) if good.size > 1 else None
        if pos is None:
            nearest = np.full(idx.size, good[0])
        else:
            left, right = good[pos - 1], good[pos]
            nearest = np.where(idx - left <= right - idx, left, right)
        R[idx] = R[nearest]
        out = replace(out, rotations=R)
    return out, n_bad
