"""Recording readers, one module per format, chosen by file suffix (``.gz`` is looked through).

>>> from streamseg.io import READERS
>>> sorted(READERS)
['.amc', '.bvh', '.c3d', '.csv', '.npy', '.npz', '.trc']

Every reader returns a :class:`~streamseg.recording.Recording`; :func:`read` then fills the
short gaps of its joint positions (:mod:`streamseg.io.gaps`), the same way the daemon fills
a live stream's.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from streamseg.exceptions import RecordingError
from streamseg.io._text import base_suffix
from streamseg.io.amc import read_amc
from streamseg.io.bvh import read_bvh
from streamseg.io.gaps import FILL_S, fill_gaps
from streamseg.io.npz import read_npz, write_npz
from streamseg.io.positions import read_positions
from streamseg.io.trc import read_trc
from streamseg.recording import Recording


def _read_c3d(path, skeleton=None, **kw):
    from streamseg.io.c3d import read_c3d  # ezc3d is imported only for a C3D file

    return read_c3d(path, skeleton, **kw)


def _read_npz(path, skeleton=None, **kw):
    """streamseg's own ``.npz``, or any other archive of joint positions."""
    try:
        with np.load(path, allow_pickle=False) as z:
            ours = "parents" in z.files and "names" in z.files
    except Exception:  # unreadable: read_npz says so
        ours = True
    if ours:
        kw.pop("joints", None)
        return read_npz(path, skeleton, **kw)
    return read_positions(path, skeleton, **kw)


READERS = {
    ".amc": read_amc,
    ".bvh": read_bvh,
    ".c3d": _read_c3d,
    ".csv": read_positions,
    ".npy": read_positions,
    ".npz": _read_npz,
    ".trc": read_trc,
}
#: readers that take ``joints=`` (the joint set of unnamed columns) or ``markers=``
_JOINTS = (".csv", ".npy", ".npz")
_MARKERS = (".c3d", ".trc")

__all__ = [
    "READERS",
    "read",
    "read_amc",
    "read_bvh",
    "read_npz",
    "read_positions",
    "read_trc",
    "write_npz",
]


def read(
    path,
    skeleton=None,
    *,
    lenient: bool = False,
    fps: float | None = None,
    joints: str | None = None,
    gap_fill: float = FILL_S,
    markers=None,
) -> Recording:
    """Read any supported recording.

    Parameters
    ----------
    path : str or Path
        ``.amc`` (optionally ``.gz``), ``.bvh``, ``.c3d``, ``.trc``, ``.npz``, or joint positions
        ``.csv``/``.npy`` (:mod:`streamseg.io.positions`).
    skeleton : str or Path, optional
        ASF skeleton, required for AMC.
    lenient : bool, default=False
        Return the good frames before a truncated last frame instead of raising (the
        recording's ``metadata["warnings"]`` says how many were dropped).
    fps : float, optional
        Override the frame rate (AMC files carry none; default 120).
    joints : str, optional
        Joint set of a positions file whose columns carry no names (``kinect``,
        ``blazepose``, ``coco17``, ``body25``).
    gap_fill : float, default :data:`~streamseg.io.gaps.FILL_S`
        Fill gaps (NaN runs) of a joint up to this many seconds by interpolation; longer
        ones stay NaN and are listed in ``metadata["gaps"]`` as ``[start, end)``. 0: none.
    markers : str or Path, optional
        A marker map (TOML, joint -> markers: :mod:`streamseg.skeleton.marker_map`) for the
        markers of a ``.c3d`` or ``.trc`` file, instead of the built-in marker sets; other
        formats ignore it.
    """
    if not Path(path).is_file():  # before anything else: a typo is not a format problem
        raise RecordingError(
            Path(path),
            None,
            "no such file" if not Path(path).exists() else "not a file",
            "the path of a recording (.amc[.gz], .bvh, .c3d, .trc, .npz, .csv, .npy)",
        )
    suffix = base_suffix(path)
    reader = READERS.get(suffix)
    if reader is None:
        raise RecordingError(
            Path(path),
            None,
            f"suffix {suffix or '(none)'!r}",
            f"one of {', '.join(sorted(READERS))} (optionally .gz)",
        )
    extra = {"joints": joints} if suffix in _JOINTS else {}
    if markers is not None and suffix in _MARKERS:
        extra["markers"] = markers
    rec = reader(path, skeleton, lenient=lenient, fps=fps, **extra)
    return with_gaps_filled(rec, gap_fill)


def with_gaps_filled(rec: Recording, seconds: float = FILL_S) -> Recording:
    """``rec`` with its short gaps filled and its long ones in ``metadata["gaps"]``."""
    from dataclasses import replace

    from streamseg.exceptions import SkeletonError
    from streamseg.skeleton.bones import bone_point_indices

    try:
        watch = np.unique(bone_point_indices(rec.skeleton))
    except SkeletonError:
        watch = None
    positions, report = fill_gaps(rec.positions, rec.fps, seconds, watch)
    meta = {
        **rec.metadata,
        "gaps": [list(g) for g in report.gaps],
        "filled_frames": report.filled_frames,
        "gap_fill_s": float(seconds),
    }
    return replace(rec, positions=positions, metadata=meta)
