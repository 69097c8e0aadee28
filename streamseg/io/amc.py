"""Acclaim motion files (AMC) posed with their ASF skeleton by forward kinematics."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from streamseg.exceptions import RecordingError, TruncatedRecordingError
from streamseg.io._text import read_text
from streamseg.io.asf import INCH_M, AcclaimSkeleton, read_asf
from streamseg.recording import Recording, Skeleton
from streamseg.skeleton.rotations import euler_to_matrix

DEFAULT_FPS = 120.0  # AMC files carry no rate; CMU and HDM05 record at 120 Hz


def _header_end(lines: list[str]) -> tuple[int, str | None]:
    """Index of the first frame-number line and the angle unit the header declares, if any."""
    unit = None
    for i, line in enumerate(lines):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if s.startswith(":"):
            low = s.lower()
            if low.startswith(":degrees"):
                unit = "deg"
            elif low.startswith(":radians"):
                unit = "rad"
            continue
        return i, unit
    return len(lines), unit


def _parse_fast(body: str, layout: list[tuple[str, int]]) -> np.ndarray | None:
    """All frames at once when every frame follows ``layout``; None when anything is off.

    Returns
    -------
    ndarray, shape (n_frames, n_values) or None
    """
    tokens = body.split()
    width = 1 + sum(1 + n for _, n in layout)
    if not tokens or len(tokens) % width:
        return None
    n_frames = len(tokens) // width
    pos, value_cols = 1, []
    for name, n in layout:
        if tokens[pos::width] != [name] * n_frames:
            return None
        value_cols.extend(range(pos + 1, pos + 1 + n))
        pos += 1 + n
    try:
        numbers = np.array(tokens[0::width], dtype=np.int64)
        values = np.array([tokens[c::width] for c in value_cols], dtype=np.float64).T
    except ValueError:
        return None
    if np.any(np.diff(numbers) != 1):
        return None
    return values.reshape(n_frames, len(value_cols))


def _parse_checked(path, lines, first, layout, known):
    """Line by line, naming the exact line of the first problem (slow path)."""
    rows, row, frame_line, expect = [], None, None, None
    widths = dict(layout)

    def close_frame(lineno):
        if row is None:
            return
        missing = [name for name, _ in layout if name not in row]
        if missing:
            raise RecordingError(
                path,
                frame_line,
                f"frame missing bone(s) {', '.join(missing)}",
                f"one line per bone: {', '.join(n for n, _ in layout)}",
            )
        rows.append(np.concatenate([row[name] for name, _ in layout]))

    last = len(lines)
    while last > first and not lines[last - 1].strip():
        last -= 1
    for idx in range(first, last):
        lineno = idx + 1
        words = lines[idx].split()
        if not words:
            continue
        try:
            if words[0].lstrip("-").isdigit() and len(words) == 1:
                close_frame(lineno)
                number = int(words[0])
                if expect is not None and number != expect:
                    raise RecordingError(
                        path, lineno, f"frame number {number}", f"frame number {expect}"
                    )
                expect, row, frame_line = number + 1, {}, lineno
                continue
            if row is None:
                raise RecordingError(
                    path, lineno, f"{lines[idx].strip()[:40]!r}", "a frame number line"
                )
            name = words[0]
            if name not in known:
                raise RecordingError(
                    path,
                    lineno,
                    f"unknown bone {name!r}",
                    f"a bone of the skeleton ({', '.join(sorted(known))})",
                )
            if name not in widths:
                raise RecordingError(
                    path,
                    lineno,
                    f"bone {name!r} not in the first frame",
                    f"the first frame's bones: {', '.join(widths)}",
                )
            try:
                vals = np.array([float(w) for w in words[1:]])
            except ValueError:
                raise RecordingError(
                    path, lineno, f"non-numeric value in {lines[idx].strip()!r}", "numbers"
                ) from None
            if len(vals) != widths[name]:
                raise RecordingError(
                    path,
                    lineno,
                    f"{len(vals)} value(s) for {name}",
                    f"{widths[name]} value(s) ({' '.join(known[name])})",
                )
            if name in row:
                raise RecordingError(
                    path, lineno, f"bone {name!r} twice in one frame", "each bone once per frame"
                )
            row[name] = vals
        except RecordingError as err:
            at_end = all(
                not lines[j].strip() or lines[j].split()[0] in widths for j in range(idx, last)
            )
            if at_end and rows:
                partial = np.array(rows)
                raise TruncatedRecordingError(
                    path,
                    err.line,
                    f"a truncated last frame ({err.found})",
                    f"complete frames; {len(rows)} good frame(s) precede it",
                    partial,
                ) from None
            raise
    try:
        close_frame(last)
    except RecordingError as err:
        if not rows:
            raise
        raise TruncatedRecordingError(
            path,
            err.line,
            f"a truncated last frame ({err.found})",
            f"complete frames; {len(rows)} good frame(s) precede it",
            np.array(rows),
        ) from None
    return np.array(rows).reshape(len(rows), sum(widths.values()))


def pose(skel: AcclaimSkeleton, layout, values: np.ndarray, unit: str):
    """Forward kinematics: AMC channel values to world joint positions and rotations.

    Each bone's world rotation is ``R_parent @ C @ M @ C.T`` with ``C`` the ASF ``axis``
    frame and ``M`` the frame's dof rotation (channels applied in the order listed); its end
    point is the parent's end point plus ``R @ (direction * length)``.

    Returns
    -------
    positions : ndarray, shape (n_frames, n_bones, 3), metres
    rotations : ndarray, shape (n_frames, n_bones, 3, 3)
    """
    n = values.shape[0]
    to_rad = np.pi / 180.0 if unit == "deg" else 1.0
    channels, col = {}, 0
    for name, width in layout:
        channels[name] = values[:, col : col + width]
        col += width
    n_bones = len(skel.bones)
    positions = np.zeros((n, n_bones, 3))
    rotations = np.zeros((n, n_bones, 3, 3))
    for i, bone in enumerate(skel.bones):
        vals = channels.get(bone.name)
        rot_axes, rot_cols, trans = [], [], np.zeros((n, 3))
        for c, dof in enumerate(bone.dof):
            if vals is None:
                break
            if dof[0] == "r":
                rot_axes.append(dof[1])
                rot_cols.append(vals[:, c] * to_rad)
            elif dof[0] == "t":
                trans[:, "xyz".index(dof[1])] = vals[:, c] / skel.length_scale * INCH_M
        m = (
            euler_to_matrix(np.stack(rot_cols, axis=1), "".join(rot_axes))
            if rot_axes
            else np.broadcast_to(np.eye(3), (n, 3, 3))
        )
        c_mat = euler_to_matrix(bone.axis[None, :], bone.axis_order)[0]
        local = c_mat @ m @ c_mat.T
        p = skel.parents[i]
        if p < 0:
            rotations[:, i] = local
            positions[:, i] = trans + skel.root_position
        else:
            rotations[:, i] = rotations[:, p] @ local
            positions[:, i] = positions[:, p] + rotations[:, i] @ (bone.direction * bone.length)
    return positions, rotations


def read_amc(path, skeleton=None, *, lenient: bool = False, fps: float | None = None) -> Recording:
    """Read an AMC file and pose it with its ASF skeleton.

    Parameters
    ----------
    path : str or Path
        ``.amc`` or ``.amc.gz``.
    skeleton : str, Path or AcclaimSkeleton
        The ASF of the same subject. Required: AMC holds only joint angles.
    lenient : bool, default=False
        When the last frame is truncated, return the good frames before it (noted in
        ``metadata["warnings"]``) instead of raising :class:`TruncatedRecordingError`.
    fps : float, optional
        Frame rate (AMC files do not store one); default 120.

    Returns
    -------
    Recording
        Positions in metres, global rotations, joint 0 = root, joint ``i`` at the end of bone
        ``i`` (the ASF convention: ``lfemur`` is the knee).
    """
    path = Path(path)
    if skeleton is None:
        raise RecordingError(
            path,
            None,
            "an AMC file without a skeleton",
            "the subject's ASF: pass --skeleton FILE.asf (e.g. data/cmu86/86.asf)",
        )
    skel = skeleton if isinstance(skeleton, AcclaimSkeleton) else read_asf(skeleton)
    lines = read_text(path).split("\n")
    first, unit = _header_end(lines)
    unit = unit or skel.angle_unit
    known = {b.name: b.dof for b in skel.bones}
    layout = []
    for idx in range(first + 1, len(lines)):
        words = lines[idx].split()
        if not words:
            continue
        if len(words) == 1 and words[0].isdigit():
            break
        if words[0] in known and words[0] not in dict(layout):
            layout.append((words[0], len(known[words[0]])))
    if first >= len(lines) or not layout:
        raise RecordingError(
            path, first + 1, "no frames", "a frame number line followed by one line per bone"
        )
    values = _parse_fast("\n".join(lines[first:]), layout)
    if values is not None:
        return _recording(path, skel, layout, values, unit, fps, [])
    try:
        values = _parse_checked(path, lines, first, layout, known)
    except TruncatedRecordingError as err:
        n = len(err.partial)
        partial = _recording(
            path,
            skel,
            layout,
            err.partial,
            unit,
            fps,
            [
                f"{Path(path).name}: the last frame (line {err.line}) is incomplete (the file was "
                f"cut off): dropped it, kept {n} frame{'s' if n != 1 else ''}"
            ],
        )
        if not lenient:
            raise TruncatedRecordingError(
                path, err.line, err.found, err.expected, partial
            ) from None
        return partial
    return _recording(path, skel, layout, values, unit, fps, [])


def _recording(path, skel, layout, values, unit, fps, warnings) -> Recording:
    positions, rotations = pose(skel, layout, values, unit)
    return Recording(
        fps=float(fps or DEFAULT_FPS),
        skeleton=Skeleton(
            skel.names,
            np.array(skel.parents),
            np.array([b.direction * b.length for b in skel.bones]),
            "m",
        ),
        positions=positions,
        rotations=rotations,
        source=str(path),
        metadata={
            "format": "amc",
            "skeleton_file": skel.path,
            "angle_unit": unit,
            "warnings": warnings,
        },
    )
