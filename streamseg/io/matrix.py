"""Plain feature matrices (rows = frames): ``.npy`` or ``.csv``, for generic methods like ACA."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from streamseg.exceptions import RecordingError

MATRIX_SUFFIXES = (".npy", ".csv")


def read_matrix(path) -> np.ndarray:
    """Read an (n_frames, d) float64 matrix from ``.npy`` or ``.csv``.

    CSV: comma-separated numbers, one frame per line; one header line of non-numeric names
    is skipped; blank lines are ignored. A 1-D ``.npy`` becomes one column.

    Raises
    ------
    RecordingError
        Naming the file (and line for CSV) of anything that is not a finite numeric matrix.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MATRIX_SUFFIXES:
        raise RecordingError(path, None, f"suffix {suffix or '(none)'!r}", "'.npy' or '.csv'")
    if not path.exists():
        raise RecordingError(path, None, "no such file", "an existing .npy or .csv file")
    if suffix == ".npy":
        try:
            X = np.load(path, allow_pickle=False)
        except (ValueError, OSError, EOFError) as err:  # EOFError: an empty or cut-off file
            raise RecordingError(
                path, None, f"unreadable .npy ({err})", "a numeric array saved by numpy.save"
            ) from None
        if X.ndim == 1:
            X = X[:, None]
        if X.ndim != 2 or X.shape[0] == 0 or not np.issubdtype(X.dtype, np.number):
            raise RecordingError(
                path,
                None,
                f"array of shape {X.shape} and dtype {X.dtype}",
                "a non-empty numeric (n_frames, d) matrix",
            )
        X = X.astype(np.float64)
        bad = np.flatnonzero(~np.all(np.isfinite(X), axis=1))
        if bad.size:
            raise RecordingError(
                path, None, f"non-finite value in row {bad[0]} (0-based)", "finite numbers"
            )
        return X
    rows = []
    width = None
    data = path.read_bytes()
    try:
        content = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise RecordingError(
            path,
            data[: err.start].count(b"\n") + 1,
            "bytes that are not UTF-8 text",
            "comma-separated numbers (a text CSV)",
        ) from None
    for lineno, line in enumerate(content.split("\n"), start=1):
        text = line.strip()
        if not text:
            continue
        fields = [f.strip() for f in text.split(",")]
        try:
            values = [float(f) for f in fields]
        except ValueError:
            if not rows and lineno == 1:
                continue  # header
            raise RecordingError(
                path, lineno, f"{text[:60]!r}", "comma-separated numbers"
            ) from None
        if not all(np.isfinite(values)):
            raise RecordingError(path, lineno, f"{text[:60]!r}", "finite numbers")
        if width is None:
            width = len(values)
        elif len(values) != width:
            raise RecordingError(
                path, lineno, f"{len(values)} columns", f"{width} columns like the first data line"
            )
        rows.append(values)
    if not rows:
        raise RecordingError(path, None, "no data lines", "at least one row of numbers")
    return np.asarray(rows, dtype=np.float64)
