"""Biovision hierarchy files (BVH), posed by forward kinematics.

Joint ``j``'s position is the origin of its frame: ``p_j = p_parent + R_parent @ offset_j``
with ``R_j = R_parent @ M_j`` and ``M_j`` the product of the joint's rotation channels in the
order listed (``Zrotation Xrotation Yrotation`` gives ``Rz @ Rx @ Ry``). End sites become joints
named ``<parent>_End``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from streamseg.exceptions import RecordingError, TruncatedRecordingError
from streamseg.io._text import read_text
from streamseg.recording import Recording, Skeleton
from streamseg.skeleton.rotations import euler_to_matrix

_CHANNELS = {"xposition", "yposition", "zposition", "xrotation", "yrotation", "zrotation"}


def _parse_hierarchy(path, lines):
    names, parents, offsets, channels = [], [], [], []
    stack, pending, i = [], None, 0
    while i < len(lines):
        words = lines[i].split()
        lineno = i + 1
        i += 1
        if not words:
            continue
        key = words[0].upper()
        if key == "HIERARCHY":
            continue
        if key in ("ROOT", "JOINT"):
            if key == "ROOT" and names:
                raise RecordingError(path, lineno, "a second ROOT", "one skeleton per file")
            if len(words) < 2:
                raise RecordingError(path, lineno, f"{key} without a name", f"{key} NAME")
            pending = (words[1], stack[-1] if stack else -1)
        elif key == "END":
            if not stack:
                raise RecordingError(path, lineno, "End Site outside a joint", "JOINT ... { }")
            pending = (f"{names[stack[-1]]}_End", stack[-1])
        elif key == "{":
            if pending is None:
                raise RecordingError(path, lineno, "'{' without a joint", "ROOT, JOINT or End Site")
            names.append(pending[0])
            parents.append(pending[1])
            offsets.append(None)
            channels.append(())
            stack.append(len(names) - 1)
            pending = None
        elif key == "}":
            if not stack:
                raise RecordingError(path, lineno, "an unmatched '}'", "balanced braces")
            stack.pop()
        elif key == "OFFSET":
            try:
                offsets[stack[-1]] = np.array([float(w) for w in words[1:4]])
            except (ValueError, IndexError):
                offsets_ok = False
            else:
                offsets_ok = len(words) >= 4
            if not offsets_ok:
                raise RecordingError(
                    path, lineno, f"{lines[lineno - 1].strip()!r}", "OFFSET x y z inside a joint"
                )
        elif key == "CHANNELS":
            try:
                n = int(words[1])
            except (ValueError, IndexError):
                n = -1
            chans = tuple(w.lower() for w in words[2:])
            if n != len(chans) or any(c not in _CHANNELS for c in chans) or not stack:
                raise RecordingError(
                    path,
                    lineno,
                    f"{lines[lineno - 1].strip()!r}",
                    "CHANNELS N followed by N of X/Y/Z position/rotation",
                )
            channels[stack[-1]] = chans
        elif key == "MOTION":
            if stack:
                raise RecordingError(path, lineno, "MOTION inside an open joint", "'}' first")
            return names, parents, offsets, channels, i
        else:
            raise RecordingError(
                path,
                lineno,
                f"{words[0]!r}",
                "ROOT, JOINT, End Site, OFFSET, CHANNELS, braces or MOTION",
            )
    raise RecordingError(path, len(lines), "end of file", "a MOTION section")


def read_bvh(path, skeleton=None, *, lenient: bool = False, fps: float | None = None) -> Recording:
    """Read a BVH file (``skeleton`` is unused: BVH carries its own).

    Parameters
    ----------
    lenient : bool, default=False
        Return the frames before a truncated last frame instead of raising.
    fps : float, optional
        Override the rate given by ``Frame Time``.
    """
    path = Path(path)
    lines = read_text(path).split("\n")
    names, parents, offsets, channels, i = _parse_hierarchy(path, lines)
    if not names:
        raise RecordingError(path, 1, "no joints", "a HIERARCHY with a ROOT")
    for j, off in enumerate(offsets):
        if off is None:
            raise RecordingError(path, None, f"joint {names[j]!r} without OFFSET", "OFFSET x y z")
    header = {}
    while i < len(lines) and len(header) < 2:
        line = lines[i].strip()
        i += 1
        if not line:
            continue
        key, _, val = line.partition(":")
        try:
            header[key.strip().lower()] = float(val)
        except ValueError:
            raise RecordingError(path, i, f"{line!r}", "'Frames: N' and 'Frame Time: T'") from None
    if (
        "frames" not in header
        or "frame time" not in header
        or not math.isfinite(header["frames"])
        or header["frames"] < 0
        or not math.isfinite(header["frame time"])
        or header["frame time"] <= 0
    ):
        raise RecordingError(
            path, i, f"header {header}", "'Frames: N' (N >= 0) and 'Frame Time: T' (finite, > 0)"
        )
    width = sum(len(c) for c in channels)
    rows, warnings = [], []
    for k in range(i, len(lines)):
        words = lines[k].split()
        if not words:
            continue
        try:
            row = [float(w) for w in words]
        except ValueError:
            row = None
        if row is None or len(row) != width:
            found = "non-numeric values" if row is None else f"{len(row)} values"
            rest = any(lines[m].strip() for m in range(k + 1, len(lines)))
            err_cls = TruncatedRecordingError if (not rest and rows) else RecordingError
            err = err_cls(path, k + 1, f"{found} in frame {len(rows)}", f"{width} values")
            if err_cls is RecordingError or not lenient:
                raise err
            said = int(header["frames"])
            lost = (
                f"{said - len(rows)} of the {said} the header announces"
                if said > len(rows)
                else "1"
            )
            warnings.append(
                f"{Path(path).name}: frame {len(rows)} (line {k + 1}) is "
                f"incomplete (the file was cut off): dropped {lost}, kept "
                f"{len(rows)}"
            )
            break
        rows.append(row)
    if len(rows) != int(header["frames"]) and not warnings:
        warnings.append(f"{path}: header says {int(header['frames'])} frames, found {len(rows)}")
    values = np.array(rows, dtype=np.float64).reshape(len(rows), width)
    positions, rotations = _pose(parents, np.array(offsets), channels, values)
    return Recording(
        float(fps or 1.0 / header["frame time"]),
        Skeleton(tuple(names), np.array(parents), np.array(offsets), "bvh"),
        positions,
        rotations,
        str(path),
        {"format": "bvh", "warnings": warnings},
    )


def _pose(parents, offsets, channels, values):
    n, n_joints = values.shape[0], len(parents)
    positions = np.zeros((n, n_joints, 3))
    rotations = np.zeros((n, n_joints, 3, 3))
    col = 0
    for j in range(n_joints):
        rot_axes, rot_cols, trans = [], [], None
        for ch in channels[j]:
            if ch.endswith("rotation"):
                rot_axes.append(ch[0])
                rot_cols.append(np.radians(values[:, col]))
            else:
                if trans is None:
                    trans = np.zeros((n, 3))
                trans[:, "xyz".index(ch[0])] = values[:, col]
            col += 1
        # Listed order multiplies left to right, i.e. the last listed axis applies first.
        local = (
            euler_to_matrix(np.stack(rot_cols[::-1], axis=1), "".join(rot_axes[::-1]))
            if rot_axes
            else np.broadcast_to(np.eye(3), (n, 3, 3))
        )
        p = parents[j]
        if p < 0:
            rotations[:, j] = local
            positions[:, j] = offsets[j] + (trans if trans is not None else 0.0)
        else:
            rotations[:, j] = rotations[:, p] @ local
            positions[:, j] = positions[:, p] + rotations[:, p] @ offsets[j]
            if trans is not None:
                positions[:, j] += np.einsum("nij,nj->ni", rotations[:, p], trans)
    return positions, rotations
