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
"""

from __future__ import annotations

import re
import zipfile
from pathlib import Path

import numpy as np

from streamseg.exceptions import RecordingError, TruncatedRecordingError
from streamseg.io._text import base_suffix, read_bytes
from streamseg.recording import Recording, Skeleton
from streamseg.skeleton.joint_sets import complete, joint_set, sets_of_size

_AXIS = re.compile(r"^(.+?)[_.\- :]([xyz])$", re.IGNORECASE)
_TIME_S = ("time", "timestamp", "t", "time_s", "seconds", "sec")
_TIME_MS = ("time_ms", "timestamp_ms", "ms")
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


def header_joints(fields) -> tuple[list, list, int | None, float] | None:
    """The joints named by a CSV header.

    Returns
    -------
    None when no column names an axis of a joint; else ``(names, columns, time_column,
    time_scale)``: joint names in order of appearance, ``columns[j]`` the (x, y, z) column
    indices of joint ``j``, the time column (None) and its seconds per unit.
    """
    axes: dict = {}
    order: list = []
    time_col, scale = None, 1.0
    for i, f in enumerate(fields):
        f = f.strip().strip('"')
        low = f.lower()
        if time_col is None and low in _TIME_S + _TIME_MS:
            time_col, scale = i, (1e-3 if low in _TIME_MS else 1.0)
            continue
        m = _AXIS.match(f)
        if not m:
            continue
        name, axis = m.group(1), m.group(2).lower()
        key = name.lower()
        if key not in axes:
            axes[key] = [name, {}]
            order.append(key)
        axes[key][1].setdefault(axis, i)
    names, columns = [], []
    for key in order:
        name, found = axes[key]
        if len(found) == 3:
            names.append(name)
            columns.append([found["x"], found["y"], found["z"]])
    if not names:
        return None
    return names, columns, time_col, scale


def _cell(text: str) -> float:
    text = text.strip().strip('"')
    return float("nan") if text == "" else float(text)


def _read_csv(path: Path, joints: str | None, lenient: bool):
    """``(positions (n, J, 3), names or None, times or None, warnings)`` of a CSV."""
    data = read_bytes(path)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise RecordingError(
            path, data[: err.start].count(b"\n") + 1, "bytes that are not UTF-8 text", "a text CSV"
        ) from None
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    first = next((i for i, line in enumerate(lines) if line.strip()), None)
    if first is None:
        raise RecordingError(path, None, "no data lines", "a header and rows of positions")
    sep = ";" if lines[first].count(";") > lines[first].count(",") else ","
    fields = lines[first].split(sep)
    header = None
    try:
        [_cell(f) for f in fields]
        start = first
    except ValueError:
        header = header_joints(fields)
        if header is None:
            raise RecordingError(
                path,
                first + 1,
                f"header {lines[first][:60]!r}",
                "columns named <joint>_x,<joint>_y,<joint>_z (joint names "
                "of a skeleton streamseg knows)",
            ) from None
        start = first + 1
    rows, width, warnings, bad_line = [], None, [], None
    body = [(n, line) for n, line in enumerate(lines[start:], start=start + 1) if line.strip()]
    for k, (lineno, line) in enumerate(body):
        cells = line.split(sep)
        if width is None:
            width = len(cells)
        try:
            values = [_cell(c) for c in cells]
            ok = len(values) == width
        except ValueError:
            ok = False
        if not ok:
            if k == len(body) - 1:  # a take cut off mid-line
                bad_line = (lineno, line)
                break
            raise RecordingError(
                path,
                lineno,
                f"{line[:60]!r}",
                f"{width} comma-separated numbers like the first row",
            )
        rows.append(values)
    if bad_line is not None:
        if not lenient:
            raise TruncatedRecordingError(
                path,
                bad_line[0],
                f"a truncated last row ({bad_line[1][:40]!r})",
                f"{width} values; {len(rows)} good frame(s) precede it",
            )
        warnings.append(
            f"{path.name}: the last row (line {bad_line[0]}) is incomplete "
            f"(the file was cut off): dropped 1 frame, kept {len(rows)}"
        )
    if not rows:
        raise RecordingError(path, None, "no data rows", "at least one row of positions")
    table = np.asarray(rows, dtype=np.float64)
    if header is not None:
        names, columns, time_col, scale = header
        pos = table[:, np.asarray(columns)]
        times = table[:, time_col] * scale if time_col is not None else None
        return pos, names, times, warnings
    return _unnamed(path, table, joints), None, None, warnings


def _unnamed(path: Path, table: np.ndarray, joints: str | None) -> np.ndarray:
    """``(n, J*3)`` or ``(n, J, 3)`` numbers without names, shaped by ``--joints``."""
    n_cols = int(np.prod(table.shape[1:]))
    if joints is None:
        shape = "x".join(str(d) for d in table.shape)
        count = n_cols // 3 if n_cols % 3 == 0 else None
        fits = sets_of_size(count) if count else []
        hint = (
            f"give --joints {'|'.join(fits)}"
            if fits
            else "give --joints kinect|blazepose|coco17|body25"
        )
        raise RecordingError(
            path,
            None,
            f"{shape} numbers without joint names",
            f"joint positions: {hint}, or name the joints (a CSV header "
            "<joint>_x,<joint>_y,<joint>_z; an .npz names array)",
        )
    js = joint_set(joints)
    want = len(js.names)
    if n_cols != 3 * want:
        raise RecordingError(
            path,
            None,
            f"{n_cols} coordinates per frame",
            f"{3 * want} ({want} joints x 3) for --joints {joints}",
        )
    return table.reshape(table.shape[0], want, 3)


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
        version = np.lib.format.read_magic(fh)
        read_header = (
            np.lib.format.read_array_header_1_0
            if version == (1, 0)
            else np.lib.format.read_array_header_2_0
        )
        shape, fortran, dtype = read_header(fh)
        offset = fh.tell()
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


def positions_recording(
    path, names, pos, rate: float, units: str, up: str, meta: dict, *, detect: bool = False
) -> Recording:
    """A recording of named joint positions, the trunk points a pose model lacks added
    (:func:`streamseg.skeleton.joint_sets.complete`); ``detect``: the up axis is the one the
    body stands along (:func:`streamseg.skeleton.bones.upright_axis`), ``up`` when no axis is
    clear."""
    names, pos = complete(names, pos)
    if detect:
        from streamseg.skeleton.bones import upright_axis

        up = upright_axis(pos, names) or up
    n = len(names)
    skel = Skeleton(tuple(names), np.full(n, -1, dtype=np.int64), np.zeros((n, 3)), units, up)
    return Recording(float(rate), skel, np.ascontiguousarray(pos), None, str(path), meta)


def _rate(times) -> float | None:
    """Frames per second from a time column (median step), or None."""
    if times is None or times.shape[0] < 2:
        return None
    steps = np.diff(times[np.isfinite(times)])
    steps = steps[steps > 0]
    if not steps.size:
        return None
    return float(round(1.0 / float(np.median(steps)), 6))


def points_recording(
    path,
    xyz: np.ndarray,
    names,
    rate: float,
    units: str,
    meta: dict,
    *,
    up: str = "y",
    noun: str = "points",
    marker_map=None,
) -> Recording:
    """Named 3-D points (C3D, TRC) as a recording.

    Markers of a set streamseg maps become its joints (joint centres where the set defines
    them, :mod:`streamseg.skeleton.marker_sets`); otherwise the names must be joints of a
    skeleton streamseg knows (:data:`streamseg.skeleton.names.POINTS`: a skeleton exported by
    an inertial suit, keypoints triangulated from video ...), a pose model's trunk added.

    Parameters
    ----------
    xyz : ndarray, shape (n_frames, n_points, 3)
        NaN where a point is missing.
    up : str
        The up axis when the body does not show one (it stands along an axis otherwise).
    noun : str
        What the file calls its points, for the error.
    marker_map : MarkerSet or path, optional
        The user's own marker set (``--markers MAP.toml``,
        :func:`streamseg.skeleton.marker_map.load_marker_map`), used instead of the built-in
        ones: every marker it names must be in the file.

    Raises
    ------
    RecordingError
        Neither a marker set nor a skeleton names the points: the markers each joint lacks.
    """
    from streamseg.exceptions import SkeletonError
    from streamseg.skeleton.bones import upright_axis
    from streamseg.skeleton.marker_sets import JOINTS, PARENTS, best_set, joint_positions
    from streamseg.skeleton.names import POINTS, resolve

    if marker_map is not None:
        from streamseg.skeleton.marker_map import load_marker_map
        from streamseg.skeleton.marker_sets import plan

        mset = (
            marker_map if not isinstance(marker_map, (str, Path)) else load_marker_map(marker_map)
        )
        chosen, missing = plan(mset, names)
        if missing and mset.pairs:  # a pair's marker the file leaves out: lost in every frame
            from streamseg.skeleton.marker_fill import with_absent_pair_markers

            more, wider = with_absent_pair_markers(names, xyz, (mset,))
            again = plan(mset, more) if len(more) > len(names) else (None, missing)
            if not again[1]:
                names, xyz = more, wider
                chosen, missing = again
        if missing:
            lack = "; ".join(f"{p} ({' '.join(m)})" for p, m in missing.items())
            raise RecordingError(
                path,
                None,
                f"{len(names)} {noun} without the markers {mset.name} names, per joint: {lack}",
                f"the file's marker names in the map (streamseg info {Path(path).name} lists them)",
            )
    else:
        mset, chosen, missing = best_set(names)
        if missing:  # a pelvis marker the file leaves out altogether: lost in every frame
            from streamseg.skeleton.marker_fill import with_absent_pair_markers

            more, wider = with_absent_pair_markers(names, xyz)
            if len(more) > len(names):
                again = best_set(more)
                if not again[2]:
                    names, xyz = more, wider
                    mset, chosen, missing = again
    if not missing:
        from streamseg.skeleton.marker_fill import fill_from_clusters

        xyz, notes = fill_from_clusters(xyz, names, mset.clusters, mset.pairs)
        from streamseg.io.gaps import fill_frames

        joints = joint_positions(xyz, names, chosen, mset, min_run=fill_frames(rate) + 1)
        gone = [p for j, p in enumerate(JOINTS) if not np.isfinite(joints[:, j]).any()]
        if gone:
            notes.append(
                f"no marker places {', '.join(gone)} in any frame: left out, the "
                "other body parts serve"
            )
        meta = {
            **meta,
            "warnings": list(meta.get("warnings", []))
            + [f"{Path(str(path)).name}: {n}" for n in notes],
        }
        skel = Skeleton(
            JOINTS,
            np.array(PARENTS),
            np.zeros((len(JOINTS), 3)),
            units,
            upright_axis(joints, JOINTS) or up,
        )
        return Recording(rate, skel, joints, None, str(path), {**meta, "marker_set": mset.name})
    try:
        resolve(complete(names, xyz[:1])[0], tuple(POINTS), POINTS)
    except SkeletonError:
        lack = "; ".join(f"{p} ({' '.join(m)})" for p, m in missing.items())
        raise RecordingError(
            path,
            None,
            f"{len(names)} {noun} ({', '.join(names[:12])}{' ...' if len(names) > 12 else ''})",
            f"a marker set streamseg maps; closest: {mset.name} "
            f"({mset.description}), which lacks, per joint: {lack}; or the "
            "joint names of a skeleton streamseg knows (docs/guide/formats.md); "
            "or a map of your own: --markers MAP.toml (streamseg info "
            f"{Path(path).name} prints a template)",
        ) from None
    return positions_recording(path, names, xyz, rate, units, up, meta, detect=True)
