"""TRC marker files (OpenSim; Motion Analysis Cortex, OpenCap, Pose2Sim and most labs export
them): named 3-D points, tab-separated.

Header (OpenSim's ``.trc``): a ``PathFileType`` line; a line of keys (``DataRate``,
``NumFrames``, ``Units`` ...) and one of their values; ``Frame#``, ``Time`` and the point
names (each followed by two empty cells); ``X1 Y1 Z1 X2 ...``. Then one row per frame. An
empty cell, ``NaN``, or a row that stops before its last points (some exporters leave trailing
gaps out) is a gap. A gzip-compressed file (``.trc.gz``) is read as it is.

The points are named in one of two ways, tried in this order:

* optical markers of a set streamseg maps (Plug-in Gait, Qualisys ...; as in C3D,
  :mod:`streamseg.skeleton.marker_sets`);
* joint or keypoint names of any skeleton streamseg knows (:data:`streamseg.skeleton.names.POINTS`:
  OpenPose BODY_25 keypoints triangulated by OpenCap or Pose2Sim, Kinect, BVH rigs ...).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from streamseg.exceptions import RecordingError, TruncatedRecordingError
from streamseg.io._text import read_bytes
from streamseg.io.positions import points_recording
from streamseg.recording import Recording


def read_trc(
    path, skeleton=None, *, lenient: bool = False, fps: float | None = None, markers=None
) -> Recording:
    """Read a TRC file's points as joints.

    Parameters
    ----------
    path : str or Path
    skeleton : unused
    lenient : bool
        Keep the frames of a file cut off (a last row incomplete, or fewer rows than
        ``NumFrames``), with a warning.
    fps : float, optional
        Replace the file's ``DataRate``.
    markers : str or Path or MarkerSet, optional
        A marker map of the user's own (``--markers MAP.toml``,
        :mod:`streamseg.skeleton.marker_map`) instead of the built-in marker sets.

    Returns
    -------
    Recording
        ``metadata`` has ``markers`` (the point names), ``marker_set`` (when a marker set
        named them) and ``warnings``.

    Raises
    ------
    RecordingError
        Not a TRC file; points that neither a marker set nor a skeleton names (with what is
        missing).
    """
    path = Path(path)
    text = read_bytes(path).decode("utf-8", errors="replace").replace("\r\n", "\n")
    lines = text.split("\n")
    if len(lines) < 5 or not lines[0].startswith("PathFileType"):
        raise RecordingError(path, 1, f"{lines[0][:40]!r}", "a TRC file (PathFileType ...)")
    keys = dict(zip(lines[1].split("\t"), lines[2].split("\t"), strict=False))
    head = lines[3].rstrip("\n").split("\t")
    if len(head) < 3 or head[0].strip() != "Frame#":
        raise RecordingError(path, 4, f"{lines[3][:40]!r}", "Frame#, Time and the point names")
    names = [head[c].strip() for c in range(2, len(head), 3) if head[c].strip()]
    width = 2 + 3 * len(names)
    rows, warnings, said = [], [], int(_number(keys.get("NumFrames")) or 0)
    body = [(i + 1, line) for i, line in enumerate(lines[5:], start=5) if line.strip()]
    for k, (lineno, line) in enumerate(body):
        cells = line.split("\t")[:width]
        try:
            row = [float(c) if c.strip() else np.nan for c in cells]
        except ValueError:
            row = []
        last = k == len(body) - 1
        if 2 <= len(row) < width and not (last and not text.endswith("\n")):
            row += [np.nan] * (width - len(row))  # trailing points left out: gaps
        if len(row) != width:
            if last:
                warnings.append(f"{path.name}: the last row (line {lineno}) is incomplete")
                break
            raise RecordingError(
                path,
                lineno,
                f"{line[:50]!r}",
                f"{width} tab-separated numbers (frame, time, x y z per point)",
            )
        rows.append(row)
    if not rows:
        raise RecordingError(path, None, "no data rows", "rows of frame, time, x y z ...")
    if warnings or (said and len(rows) < said):
        if not lenient:
            raise TruncatedRecordingError(
                path,
                None,
                f"{len(rows)} whole frames of the {said or len(rows) + 1} the file announces",
                "a complete TRC file",
            )
        warnings = [
            f"{path.name}: the file was cut off: {len(rows)} frames of the "
            f"{max(said or 0, len(rows) + 1)} it announces kept"
        ]
    table = np.asarray(rows, dtype=np.float64)
    xyz = table[:, 2:].reshape(len(rows), len(names), 3)
    rate = fps or _number(keys.get("DataRate")) or _number(keys.get("CameraRate"))
    if not rate:
        raise RecordingError(path, 3, "no DataRate", "a TRC DataRate > 0, or --fps")
    units = (keys.get("Units") or "unknown").strip()
    meta = {"format": "trc", "markers": names, "warnings": warnings}
    return points_recording(
        path,
        xyz,
        names,
        float(rate),
        units,
        meta,  # OpenSim: y up
        marker_map=markers,
    )


def _number(text) -> float | None:
    try:
        value = float(str(text).strip())
    except ValueError:
        return None
    return value if np.isfinite(value) and value > 0 else None
