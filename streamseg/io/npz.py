"""streamseg's native recording format: one ``.npz`` that loads in milliseconds.

Positions are read eagerly; rotations, four times their size and needed only by rotation
features, are memory-mapped straight out of the (uncompressed) archive, so they cost nothing
until used. A compressed archive (``write_npz(..., compress=True)``) is read eagerly.

Arrays: ``positions`` (n_frames, n_joints, 3) float64, optional ``rotations``
(n_frames, n_joints, 3, 3), ``parents`` (n_joints,), ``offsets`` (n_joints, 3), ``names``
(n_joints,) str, ``fps`` scalar, ``units`` str, ``up`` str (optional, default ``"y"``),
``metadata`` a JSON string, ``version`` int.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from streamseg import strict_json
from streamseg.exceptions import RecordingError
from streamseg.recording import Recording, Skeleton

VERSION = 1
_REQUIRED = ("positions", "parents", "offsets", "names", "fps")


def write_npz(path, recording: Recording, *, compress: bool = False) -> None:
    """Save ``recording`` (positions, rotations, skeleton, fps, metadata) to ``path``."""
    arrays = {
        "version": np.int64(VERSION),
        "positions": recording.positions,
        "parents": np.asarray(recording.skeleton.parents, dtype=np.int64),
        "offsets": np.asarray(recording.skeleton.offsets, dtype=np.float64),
        "names": np.array(recording.skeleton.names, dtype=str),
        "fps": np.float64(recording.fps),
        "units": np.array(recording.skeleton.units),
        "up": np.array(recording.skeleton.up),
        "metadata": np.array(
            strict_json.dumps({**recording.metadata, "source": recording.source}, default=str)
        ),
    }
    if recording.rotations is not None:
        arrays["rotations"] = recording.rotations
    (np.savez_compressed if compress else np.savez)(path, **arrays)


def npy_header(fh) -> tuple:
    """``(shape, fortran_order, dtype, data_offset)`` of the ``.npy`` header at ``fh``'s
    position (format 1.0 or 2.0)."""
    version = np.lib.format.read_magic(fh)
    read_header = (
        np.lib.format.read_array_header_1_0
        if version == (1, 0)
        else np.lib.format.read_array_header_2_0
    )
    shape, fortran, dtype = read_header(fh)
    return shape, fortran, dtype, fh.tell()


def _mapped(path: Path, member: str) -> np.ndarray | None:
    """Read-only memory map of an uncompressed ``.npy`` member of a zip archive, else None."""
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo(member)
    if info.compress_type != zipfile.ZIP_STORED:
        return None
    with open(path, "rb") as fh:
        fh.seek(info.header_offset)
        local = fh.read(30)  # zip local file header: name and extra lengths at bytes 26-29
        fh.seek(
            info.header_offset
            + 30
            + int.from_bytes(local[26:28], "little")
            + int.from_bytes(local[28:30], "little")
        )
        shape, fortran, dtype, offset = npy_header(fh)
    return np.memmap(
        path, dtype=dtype, mode="r", offset=offset, shape=shape, order="F" if fortran else "C"
    )


def read_npz(path, skeleton=None, *, lenient: bool = False, fps: float | None = None) -> Recording:
    """Load a recording written by :func:`write_npz` (``skeleton`` and ``lenient`` unused)."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            missing = [k for k in _REQUIRED if k not in z.files]
            if missing:
                raise RecordingError(
                    path,
                    None,
                    f"arrays {sorted(z.files)}",
                    f"also {', '.join(missing)} (a streamseg .npz)",
                )
            version = int(z["version"]) if "version" in z.files else VERSION
            if version > VERSION:
                raise RecordingError(
                    path,
                    None,
                    f"format version {version}",
                    f"version <= {VERSION}: upgrade streamseg",
                )
            positions = z["positions"].astype(np.float64, copy=False)
            names = tuple(str(n) for n in z["names"])
            if positions.ndim != 3 or positions.shape[1:] != (len(names), 3):
                raise RecordingError(
                    path,
                    None,
                    f"positions of shape {positions.shape}",
                    f"(n_frames, {len(names)}, 3)",
                )
            rotations = _mapped(path, "rotations.npy") if "rotations" in z.files else None
            if rotations is None and "rotations" in z.files:
                rotations = z["rotations"]
            meta = json.loads(str(z["metadata"])) if "metadata" in z.files else {}
            skel = Skeleton(
                names,
                z["parents"],
                z["offsets"],
                str(z["units"]) if "units" in z.files else "unknown",
                str(z["up"]) if "up" in z.files else "y",
            )
            rate = float(fps or z["fps"])
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as err:
        if isinstance(err, FileNotFoundError):
            raise RecordingError(path, None, "no such file", "an existing .npz") from None
        raise RecordingError(
            path, None, f"an unreadable archive ({err})", "a .npz written by streamseg (np.savez)"
        ) from None
    source = meta.pop("source", str(path))
    return Recording(rate, skel, positions, rotations, source, {**meta, "format": "npz"})
