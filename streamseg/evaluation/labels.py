"""Human label files: ``sequence,start_frame,end_frame,action_label[,boundary_lo,boundary_hi]``.

The files use 1-based inclusive AMC frame numbers; everything returned here is 0-based with
exclusive ends. A cut at frame ``c`` means a new segment starts at ``c``.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from streamseg.exceptions import RecordingError


@dataclass(frozen=True)
class LabelSegment:
    """One labelled segment.

    Attributes
    ----------
    start, end : int
        0-based first frame and exclusive end.
    label : str
        The annotators' action name.
    lo, hi : int
        Window of acceptable positions (0-based, inclusive) for the cut that ends this
        segment, i.e. for ``end``. Without boundary columns both equal ``end``.
    """

    start: int
    end: int
    label: str
    lo: int
    hi: int


def read_labels(path, sequence: str) -> list[LabelSegment]:
    """Read the rows of ``sequence`` from a label CSV, in time order.

    Raises
    ------
    RecordingError
        Naming the file and line of a malformed row, or when no row matches ``sequence``.
    """
    path = Path(path)
    out = []
    with io.StringIO(_text(path), newline="") as fh:
        rows = csv.reader(fh)
        header = next(rows, None)
        if not header or header[:4] != ["sequence", "start_frame", "end_frame", "action_label"]:
            raise RecordingError(
                path,
                1,
                f"header {header!r}",
                "sequence,start_frame,end_frame,action_label[,boundary_lo,boundary_hi]",
            )
        has_window = header[4:6] == ["boundary_lo", "boundary_hi"]
        seen = []
        for lineno, row in enumerate(rows, start=2):
            if not row:
                continue
            seen.append(row[0])
            if row[0] != sequence:
                continue
            try:
                start, end = int(row[1]) - 1, int(row[2])
                lo, hi = (int(row[4]) - 1, int(row[5])) if has_window else (end, end)
            except (ValueError, IndexError):
                raise RecordingError(
                    path, lineno, f"row {row!r}", "integer frame numbers in columns 2-3 (and 5-6)"
                ) from None
            if start < 0:
                raise RecordingError(
                    path,
                    lineno,
                    f"start_frame {start + 1}",
                    "1-based frame numbers (the first frame is 1)",
                )
            if end <= start:
                raise RecordingError(
                    path, lineno, f"start {start + 1} > end {end}", "start_frame <= end_frame"
                )
            out.append(LabelSegment(start, end, row[3], min(lo, end), max(hi, end)))
    if not out:
        raise RecordingError(
            path, None, f"no rows for sequence {sequence!r}", f"one of {sorted(set(seen))}"
        )
    out.sort(key=lambda s: s.start)
    return out


def _text(path) -> str:
    """The file as text; one that is not UTF-8 is a :class:`RecordingError` at its line."""
    data = path.read_bytes()
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise RecordingError(
            path,
            data[: err.start].count(b"\n") + 1,
            "bytes that are not UTF-8 text",
            "a label CSV (sequence,start_frame,end_frame,action_label)",
        ) from None


def true_cuts(segments: list[LabelSegment], n_frames: int | None = None) -> list[int]:
    """Cut frames between consecutive labelled segments (the recording's end is no cut)."""
    cuts = [s.end for s in segments[:-1]]
    return [c for c in cuts if n_frames is None or c < n_frames]


def cut_windows(segments: list[LabelSegment]) -> list[tuple[int, int]]:
    """``(lo, hi)`` acceptance window of each true cut, aligned with :func:`true_cuts`."""
    return [(s.lo, s.hi) for s in segments[:-1]]


def frame_labels(segments: list[LabelSegment], n_frames: int) -> np.ndarray:
    """Per-frame integer label (index into the sorted set of label names); -1 where unlabelled.

    Returns
    -------
    ndarray of int, shape (n_frames,)
    """
    names = sorted({s.label for s in segments})
    out = np.full(n_frames, -1, dtype=np.int64)
    for s in segments:
        out[s.start : min(s.end, n_frames)] = names.index(s.label)
    return out
