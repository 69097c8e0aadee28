"""Joint positions in a ``.npy`` or an ``.npz`` (a cut-off ``.npy`` keeps its whole frames),
and what 2-D keypoints and per-frame normalised landmarks are taken as."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from streamseg.exceptions import RecordingError, TruncatedRecordingError
from streamseg.io.npz import npy_header

_ARRAY_KEYS = (
    "positions",
    "joints3d",
    "joints_3d",
    "keypoints3d",
    "keypoints_3d",
    "keypoints",
    "landmarks",
    "world_landmarks",
    "poses",
    "joints",
    "data",
)
_NAME_KEYS = ("names", "joint_names", "joints_names", "landmark_names")
_FPS_KEYS = ("fps", "framerate", "frame_rate", "mocap_framerate", "rate")


def _read_array(path: Path, lenient: bool):
    """``(array, names or None, fps or None)`` of a ``.npy`` or a non-streamseg ``.npz``."""
    try:
        if path.suffix.lower() == ".npy":
            return _load_npy(path, lenient), None, None, []
        with np.load(path, allow_pickle=False) as z:
            key = next((k for k in _ARRAY_KEYS if k in z.files and z[k].ndim in (2, 3)), None)
            if key is None:
                arrays = [k for k in z.files if z[k].ndim == 3 and z[k].shape[-1] == 3]
                key = arrays[0] if len(arrays) == 1 else None
            if key is None:
                raise RecordingError(
                    path,
                    None,
                    f"arrays {sorted(z.files)}",
                    "an array of joint positions (n_frames, n_joints, 3) "
                    f"named one of {', '.join(_ARRAY_KEYS)}",
                )
            names = next((tuple(str(x) for x in z[k]) for k in _NAME_KEYS if k in z.files), None)
            fps = next((float(z[k]) for k in _FPS_KEYS if k in z.files and z[k].size == 1), None)
            return np.asarray(z[key]), names, fps, []
    except (zipfile.BadZipFile, ValueError, OSError) as err:
        raise RecordingError(
            path, None, f"an unreadable array file ({err})", "a .npy or .npz written by numpy"
        ) from None


def _load_npy(path: Path, lenient: bool) -> np.ndarray:
    """A ``.npy``; one cut off keeps its whole frames with ``lenient`` (a warning upstream)."""
    try:
        return np.load(path, allow_pickle=False)
    except ValueError:
        pass  # numpy: "cannot reshape array of size ..." on a short file
    with open(path, "rb") as fh:
        shape, fortran, dtype, offset = npy_header(fh)
    size = path.stat().st_size - offset
    per_frame = int(np.prod(shape[1:], dtype=np.int64)) * dtype.itemsize
    n_good = size // per_frame if per_frame and not fortran else 0
    if not lenient or n_good == 0:
        raise TruncatedRecordingError(
            path,
            None,
            f"{n_good} whole frames of {shape[0]}",
            f"{shape[0]} frames (the file was cut off)",
        )
    arr = np.memmap(path, dtype=dtype, mode="r", offset=offset, shape=(n_good,) + tuple(shape[1:]))
    out = np.array(arr)
    out.flags.writeable = True
    return _Truncated(out, shape[0])


class _Truncated(np.ndarray):
    """An array read from a cut-off ``.npy``, remembering the frames its header promised."""

    def __new__(cls, arr, promised):
        obj = np.asarray(arr).view(cls)
        obj.promised = promised
        return obj


def _image_keypoints(arr):
    """2-D keypoints ``(n, J, 2)`` as points ``(n, J, 3)`` in the image plane (depth 0);
    a keypoint at exactly (0, 0), the "not found" of OpenPose and COCO, is a gap."""
    out = np.concatenate([arr, np.zeros(arr.shape[:2] + (1,))], axis=2)
    out[(arr == 0).all(axis=2)] = np.nan
    return out, (
        "2-D keypoints: taken as image coordinates (x right, y down; depth 0), "
        "a keypoint at (0, 0) as not found"
    )


def meta_image(warnings) -> bool:
    """Whether the reader took the file's keypoints as 2-D image coordinates."""
    return any("2-D keypoints" in w for w in warnings)


def _normalised_image(pos) -> str:
    """What a pose whose every frame spans exactly [0, 1] on x and y is (MediaPipe image
    landmarks min-max normalised per frame), or ""."""
    good = np.isfinite(pos).all(axis=2).all(axis=1)
    if good.sum() < 2:
        return ""
    P = pos[good]
    lo, hi = P.min(axis=1), P.max(axis=1)  # (n, 3)
    if np.allclose(lo[:, :2], 0, atol=1e-3) and np.allclose(hi[:, :2], 1, atol=1e-3):
        return (
            "every frame spans [0, 1] on x and y: taken as image landmarks normalised "
            "per frame (x right, y down; z the model's relative depth); body size and "
            "place in the image are lost, bone directions serve"
        )
    return ""
