"""Joint positions as a table or array: ``.csv``, ``.npy``, ``.npz`` (Kinect, pose models,
any skeleton exported as positions).

* CSV with a header naming each coordinate ``<joint>_x, <joint>_y, <joint>_z`` (case free;
  ``_``, ``.``, ``-``, `` `` or ``:`` before the axis): the names of any skeleton streamseg
  maps (:data:`streamseg.skeleton.names.POINTS`: CMU/HDM05 ASF, BVH rigs, Kinect v2,
  BlazePose, COCO, BODY_25). Other columns are ignored, except a time column (``time``,
  ``timestamp``, ``t`` in seconds, ``time_ms``/``timestamp_ms`` in milliseconds), which gives
  the frame rate when ``--fps`` does not. Empty cells and ``nan`` are gaps.
* CSV without a header, or ``.npy`` of shape ``(n, n_joints * 3)``: ``--joints NAME`` names
  the columns (:data:`streamseg.skeleton.joint_sets.JOINT_SETS`).
* ``.npy`` or an ``.npz`` member of shape ``(n, n_joints, 3)``; an ``.npz`` may name its joints
  (``names``/``joint_names``/``joints`` array of str) and rate (``fps``/``framerate``/
  ``mocap_framerate``).

Pose models have no pelvis, spine or neck: they are added as virtual joints
(:func:`streamseg.skeleton.joint_sets.complete`).

Image-space pose (a phone camera's): 2-D keypoints ``(n, J, 2)`` (or ``(n, J * 2)`` with
``--joints``) are image coordinates (x right, y down) with depth 0, a keypoint at exactly
(0, 0) not found; a pose whose every frame spans exactly [0, 1] on x and y is taken as image
landmarks normalised per frame (MediaPipe's, as some pipelines prepare them); frames without
any keypoint (no person) are gaps. A warning says what was assumed.

The CSV reader is :mod:`~streamseg.io.positions_csv`, the array reader
:mod:`~streamseg.io.positions_arrays`; :mod:`~streamseg.io.points` makes the recording.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from streamseg.exceptions import RecordingError
from streamseg.io._text import base_suffix
from streamseg.io.points import points_recording, positions_recording
from streamseg.io.positions_arrays import (
    _image_keypoints,
    _normalised_image,
    _read_array,
    _Truncated,
    meta_image,
)
from streamseg.io.positions_csv import _read_csv, _unnamed, header_joints
from streamseg.recording import Recording
from streamseg.skeleton.joint_sets import joint_set

__all__ = [
    "header_joints",
    "meta_image",
    "points_recording",
    "positions_recording",
    "read_positions",
]


def read_positions(
    path,
    skeleton=None,
    *,
    lenient: bool = False,
    fps: float | None = None,
    joints: str | None = None,
) -> Recording:
    """Read joint positions from ``.csv``, ``.npy`` or ``.npz``.

    Parameters
    ----------
    path : str or Path
    skeleton : unused
        (The reader interface; positions need no ASF.)
    lenient : bool
        Keep the whole frames of a file cut off mid-frame (with a warning) instead of
        raising :class:`TruncatedRecordingError`.
    fps : float, optional
        Frame rate; needed unless the file gives one (an ``.npz`` ``fps``, a CSV time column).
    joints : str, optional
        Joint set of unnamed columns (:data:`streamseg.skeleton.joint_sets.JOINT_SETS`).

    Raises
    ------
    RecordingError
        With what is missing and the flag that supplies it.
    """
    path = Path(path)
    times = None
    if base_suffix(path) == ".csv":
        pos, names, times, warnings = _read_csv(path, joints, lenient)
        file_fps = None
    else:
        arr, names, file_fps, warnings = _read_array(path, lenient)
        if isinstance(arr, _Truncated):
            warnings.append(
                f"{path.name}: the file was cut off: {arr.shape[0]} whole frames "
                f"of {arr.promised} kept ({arr.promised - arr.shape[0]} dropped)"
            )
        arr = np.asarray(arr, dtype=np.float64)
        if joints and arr.ndim == 2 and arr.shape[1] == 2 * len(joint_set(joints).names):
            arr = arr.reshape(arr.shape[0], -1, 2)
        if arr.ndim == 3 and arr.shape[2] == 2 and arr.shape[0]:
            arr, note = _image_keypoints(arr)
            warnings.append(f"{path.name}: {note}")
        if (
            not np.issubdtype(arr.dtype, np.number)
            or arr.ndim not in (2, 3)
            or (arr.ndim == 3 and arr.shape[2] != 3)
            or arr.shape[0] == 0
        ):
            raise RecordingError(
                path,
                None,
                f"an array of shape {arr.shape}",
                "joint positions (n_frames, n_joints, 3) or "
                "(n_frames, n_joints * 3) with --joints; image keypoints "
                "(n_frames, n_joints, 2)",
            )
        if names is not None and arr.ndim == 3 and len(names) == arr.shape[1]:
            pos = arr
        else:
            pos = _unnamed(path, arr, joints)
            names = None
    units, up, detect = "unknown", "y", True  # named joints: any producer, any frame
    if names is None:
        js = joint_set(joints)
        names, units, up, detect = js.names, js.units, js.up, not js.fixed_up
    rate = fps or file_fps or _rate(times)
    if rate is None:
        raise RecordingError(
            path,
            None,
            "no frame rate",
            "--fps (frames per second), or a "
            "time column (time, timestamp: seconds; time_ms) in the CSV",
        )
    if meta_image(warnings):
        units = "image"
    elif pos.size and units in ("m", "unknown"):
        note = _normalised_image(pos)
        if note:
            warnings.append(f"{path.name}: {note}")
            units = "normalised image"
    absent = int((~np.isfinite(pos).any(axis=(1, 2))).sum()) if pos.size else 0
    if absent:
        warnings.append(
            f"{path.name}: {absent} of {pos.shape[0]} frames have no keypoint "
            "(no person found): gaps"
        )
    meta = {"format": "positions", "warnings": warnings}
    if joints:
        meta["joints"] = joints
    return positions_recording(path, names, pos, float(rate), units, up, meta, detect=detect)


def _rate(times) -> float | None:
    """Frames per second from a time column (median step), or None."""
    if times is None or times.shape[0] < 2:
        return None
    steps = np.diff(times[np.isfinite(times)])
    steps = steps[steps > 0]
    if not steps.size:
        return None
    return float(round(1.0 / float(np.median(steps)), 6))
