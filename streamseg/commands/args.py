"""Argument types and checks shared by the command modules (light: standard library only)."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

from streamseg.exceptions import ParameterError

# the daemon's default max_fps: no motion-capture system or pose model runs faster
MAX_FPS = 10000.0


def frame_rate(text: str) -> float:
    """An ``--fps`` value: a finite number > 0 (argparse type; else a one-line usage error)."""
    try:
        fps = float(text)
    except ValueError:
        fps = float("nan")
    if not (math.isfinite(fps) and 0 < fps <= MAX_FPS):
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected a frame rate in frames per second, a finite number > 0 and "
            f"at most {MAX_FPS:g} (e.g. 120)"
        )
    return fps


def endpoint(text: str) -> str:
    """A ZeroMQ endpoint to connect to (argparse type): ``tcp://HOST:PORT`` with a port in
    1..65535, or ``ipc://`` / ``inproc://``; else a one-line usage error (ZeroMQ would accept
    some bad ones and wait for a peer that can never come)."""
    scheme, sep, rest = text.partition("://")
    if sep and scheme in ("ipc", "inproc") and rest:
        return text
    host, _, port = rest.rpartition(":")
    if scheme == "tcp" and host and port.isdigit() and 1 <= int(port) <= 65535:
        return text
    raise argparse.ArgumentTypeError(
        f"{text!r}: expected an endpoint tcp://HOST:PORT with a "
        "port in 1..65535 (e.g. tcp://127.0.0.1:5560)"
    )


def add_input_arguments(
    p: argparse.ArgumentParser, optional: bool = False, write_events: bool = False
) -> None:
    """FILE, --skeleton and --fps, as every command reading one recording takes them, and
    the reading flags of :func:`streamseg.commands.inputs.add_source_arguments`."""
    from streamseg.commands.inputs import add_source_arguments

    p.add_argument(
        "file",
        nargs="?" if optional else None,
        help="recording (.amc[.gz], .bvh, .c3d, .trc, .npz; joint positions .csv/.npy/.npz) or "
        "feature matrix (.npy, .csv)",
    )
    p.add_argument("--skeleton", help="ASF skeleton file (needed for AMC)")
    p.add_argument(
        "--fps",
        type=frame_rate,
        default=None,
        help="frame rate: needed for a feature matrix (.npy/.csv, rows per second) and for "
        "positions without a time column; for a recording it replaces the file's own "
        "(AMC: 120)",
    )
    add_source_arguments(p, write_events=write_events)


def check_plot(plot, need_matplotlib: bool = True) -> None:
    """Fail before the work, not after it, on a picture that cannot be written."""
    if not plot:
        return
    path = Path(plot)
    if path.suffix.lower() != ".png":
        raise ParameterError(f"--plot {plot}: expected a .png file name")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ParameterError(
            f"--plot {plot}: folder {folder} does not exist (create it or choose another path)"
        )
    if not os.access(folder, os.W_OK):
        raise ParameterError(f"--plot {plot}: folder {folder} is not writable")
    if not need_matplotlib:
        return
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise ParameterError("--plot needs matplotlib: pip install 'streamseg[plot]'") from None
