"""Reading motion-capture text files as people have them: gzip or plain, CRLF/LF/mixed, Latin-1."""

from __future__ import annotations

import gzip
from pathlib import Path

from streamseg.exceptions import RecordingError


def read_text(path) -> str:
    """Whole file as text with ``\\n`` line ends.

    Latin-1 maps every byte to a character, so header comments with non-UTF-8 bytes (HDM05)
    never fail; the numeric body is ASCII either way. A ``.gz`` suffix is decompressed.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        # read_text serves recordings and ASF skeletons alike: say what to check, not which
        raise RecordingError(
            path, None, "no such file", "an existing file (check the path)"
        ) from None
    except IsADirectoryError:
        raise RecordingError(path, None, "a directory", "a file") from None
    raw = _gunzipped(path, raw)
    if b"\x00" in raw[:4096]:
        raise RecordingError(path, 1, "binary data (NUL bytes)", "a text file")
    return raw.decode("latin-1").replace("\r\n", "\n").replace("\r", "\n")


def read_bytes(path) -> bytes:
    """The file's bytes, decompressed when they are a gzip stream (whatever the suffix)."""
    path = Path(path)
    return _gunzipped(path, path.read_bytes())


def _gunzipped(path, raw: bytes) -> bytes:
    """``raw`` decompressed when it is a gzip stream (whatever the file's suffix)."""
    if raw[:2] != b"\x1f\x8b":
        return raw
    try:
        return gzip.decompress(raw)
    except (OSError, EOFError) as err:
        raise RecordingError(
            path, None, f"a broken gzip stream ({err})", "a complete gzip file"
        ) from None


def base_suffix(path) -> str:
    """Format suffix ignoring a trailing ``.gz`` (``86_01.amc.gz`` -> ``.amc``)."""
    suffixes = [s.lower() for s in Path(path).suffixes]
    if suffixes and suffixes[-1] == ".gz":
        suffixes = suffixes[:-1]
    return suffixes[-1] if suffixes else ""
