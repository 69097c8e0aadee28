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


#: lines split off a file's text to find its header's end and its first frame's layout
_HEAD_LINES = 4096


def _head(lines: list[str], known: dict) -> tuple[int, str | None, list, bool]:
    """The first frame-number line, the header's angle unit, the first frame's layout
    ``[(bone, n_values)]``, and whether the next frame-number line (or the end) was seen."""
    first, unit = _header_end(lines)
    layout = []
    for idx in range(first + 1, len(lines)):
        words = lines[idx].split()
        if not words:
            continue
        if len(words) == 1 and words[0].isdigit():
            return first, unit, layout, True
        if words[0] in known and words[0] not in dict(layout):
            layout.append((words[0], len(known[words[0]])))
    return first, unit, layout, False


def _parse_fast(body: bytes, layout: list[tuple[str, int]]) -> np.ndarray | None:
    """All frames at once when every frame follows ``layout``; None when anything is off.

    One pass over the bytes (:mod:`streamseg._kernels.amc_text`): plain ASCII whose tokens
    sit where ``layout`` puts them, frame numbers counting up by one, every value a decimal
    number it converts exactly as ``float`` does. Anything else (non-ASCII bytes, ``nan``,
    more than 15 significant digits, a misplaced or misspelt bone) is left to the
    line-by-line reader, which gives the same numbers or names the line.

    Returns
    -------
    ndarray, shape (n_frames, n_values) or None
    """
    from streamseg._kernels import amc_text

    buf = np.frombuffer(body, dtype=np.uint8)
    kinds, starts, lengths, names = [amc_text.FRAME], [0], [0], b""
    for name, n in layout:
        word = name.encode("latin-1")
        kinds += [amc_text.NAME] + [amc_text.VALUE] * n
        starts += [len(names)] + [0] * n
        lengths += [len(word)] + [0] * n
        names += word
    width = len(kinds)
    n_tokens = amc_text.count_tokens(buf)
    if n_tokens <= 0 or n_tokens % width:
        return None
    n_frames = n_tokens // width
    out = np.empty((n_frames, width - 1 - len(layout)))
    failed = amc_text.parse_frames(
        buf,
        np.array(kinds, dtype=np.int64),
        np.array(starts, dtype=np.int64),
        np.array(lengths, dtype=np.int64),
        np.frombuffer(names, dtype=np.uint8),
        n_frames,
        out,
    )
    return out if failed < 0 else None


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
    point is the parent's end point plus ``R @ (direction * length)``. The root's end point
    is the ASF root position plus its translation channels. Bones the file gives no values
    for keep ``M = I``.

    Returns
    -------
    positions : ndarray, shape (n_frames, n_bones, 3), metres
    rotations : ndarray, shape (n_frames, n_bones, 3, 3)
    """
    from streamseg._kernels.kinematics import IGNORED, TRANSLATION, pose_frames

    n, n_bones = values.shape[0], len(skel.bones)
    start, col = {}, 0
    for name, width in layout:
        start[name] = col
        col += width
    if values.shape[1] != col:
        raise ValueError(f"values of {values.shape[1]} channels for a layout of {col}")
    most = max([len(bone.dof) for bone in skel.bones] + [1])
    kinds = np.full((n_bones, most), -1, dtype=np.int64)
    cols = np.zeros((n_bones, most), dtype=np.int64)
    for i, bone in enumerate(skel.bones):
        if bone.name not in start:
            continue
        for c, dof in enumerate(bone.dof):
            if dof[0] == "r":
                kinds[i, c] = "xyz".index(dof[1])
            elif dof[0] == "t":
                kinds[i, c] = TRANSLATION + "xyz".index(dof[1])
            else:
                kinds[i, c] = IGNORED
            cols[i, c] = start[bone.name] + c
    frames = np.array(
        [euler_to_matrix(bone.axis[None, :], bone.axis_order)[0] for bone in skel.bones]
    ).reshape(n_bones, 3, 3)
    offsets = np.array([bone.direction * bone.length for bone in skel.bones]).reshape(n_bones, 3)
    positions = np.empty((n, n_bones, 3))
    rotations = np.empty((n, n_bones, 3, 3))
    pose_frames(
        np.ascontiguousarray(values, dtype=np.float64),
        np.array(skel.parents, dtype=np.int64),
        kinds,
        cols,
        frames,
        offsets,
        np.asarray(skel.root_position, dtype=np.float64),
        np.pi / 180.0 if unit == "deg" else 1.0,
        float(skel.length_scale),
        INCH_M,
        positions,
        rotations,
    )
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
    text = read_text(path)
    known = {b.name: b.dof for b in skel.bones}
    # the header and the first frame are all the one-pass parse needs as lines
    lines = text.split("\n", _HEAD_LINES)
    first, unit, layout, ended = _head(lines, known)
    if not ended and len(lines) > _HEAD_LINES:
        lines = text.split("\n")
        first, unit, layout, ended = _head(lines, known)
    unit = unit or skel.angle_unit
    if first >= len(lines) or not layout:
        raise RecordingError(
            path, first + 1, "no frames", "a frame number line followed by one line per bone"
        )
    offset = sum(len(line) + 1 for line in lines[:first])
    values = _parse_fast(text[offset:].encode("latin-1"), layout)
    if values is not None:
        return _recording(path, skel, layout, values, unit, fps, [])
    lines = text.split("\n")
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
