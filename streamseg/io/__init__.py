"""Recording readers, one module per format, chosen by file suffix (``.gz`` is looked through).

>>> from streamseg.io import READERS
>>> sorted(READERS)
['.amc', '.bvh', '.npz']
"""

from __future__ import annotations

from pathlib import Path

from streamseg.exceptions import RecordingError
from streamseg.io._text import base_suffix
from streamseg.io.amc import read_amc
from streamseg.io.bvh import read_bvh
from streamseg.io.npz import read_npz, write_npz
from streamseg.recording import Recording

READERS = {".amc": read_amc, ".bvh": read_bvh, ".npz": read_npz}

__all__ = ["READERS", "read", "read_amc", "read_bvh", "read_npz", "write_npz"]


def read(path, skeleton=None, *, lenient: bool = False, fps: float | None = None) -> Recording:
    """Read any supported recording.

    Parameters
    ----------
    path : str or Path
        ``.amc`` (optionally ``.gz``), ``.bvh`` or ``.npz``.
    skeleton : str or Path, optional
        ASF skeleton, required for AMC.
    lenient : bool, default=False
        Return the good frames before a truncated last frame instead of raising.
    fps : float, optional
        Override the frame rate (AMC files carry none; default 120).
    """
    if not Path(path).is_file():  # before anything else: a typo is not a format problem
        raise RecordingError(Path(path), None,
                             "no such file" if not Path(path).exists() else "not a file",
                             "the path of a recording (.amc[.gz], .bvh, .npz)")
    suffix = base_suffix(path)
    reader = READERS.get(suffix)
    if reader is None:
        raise RecordingError(
            Path(path),
            None,
            f"suffix {suffix or '(none)'!r}",
            f"one of {', '.join(sorted(READERS))} (optionally .gz)",
        )
    return reader(path, skeleton, lenient=lenient, fps=fps)
