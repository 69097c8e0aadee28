"""Joint positions in a CSV: a header naming each coordinate ``<joint>_x, _y, _z`` (and a
time column), or unnamed columns shaped by ``--joints``."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from streamseg.exceptions import RecordingError, TruncatedRecordingError
from streamseg.io._text import read_bytes
from streamseg.skeleton.joint_sets import joint_set, sets_of_size

_AXIS = re.compile(r"^(.+?)[_.\- :]([xyz])$", re.IGNORECASE)
_TIME_S = ("time", "timestamp", "t", "time_s", "seconds", "sec")
_TIME_MS = ("time_ms", "timestamp_ms", "ms")


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
