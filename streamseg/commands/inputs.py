"""How every command reads its input recording: the flags and the one reading path.

``--joints`` names the columns of a positions file that has none, ``--strict`` refuses a
truncated file (by default its good frames are kept, with a warning saying how many were
dropped), ``--gap-fill S`` sets the longest gap filled by interpolation. Warnings about the
file (truncation, gaps the detectors skip) go to stderr and into the JSON (``warnings``,
``gaps``). ``segment --write-events OUT.c3d`` writes the result into a copy of a C3D input.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from streamseg.commands.output import warn
from streamseg.exceptions import ParameterError

MATRIX_SUFFIXES = (".npy", ".csv")
#: streamseg.io.gaps.FILL_S, here without importing numpy (the parser is built first)
FILL_S = 0.25


def _seconds(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        v = float("nan")
    if not (v >= 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r}: expected seconds >= 0 (0: fill nothing)")
    return v


def add_source_arguments(p, *, write_events: bool = False) -> None:
    """The reading flags (and ``--write-events`` for ``segment``)."""
    from streamseg.skeleton.joint_sets import JOINT_SETS

    p.add_argument(
        "--joints",
        choices=sorted(JOINT_SETS),
        type=str.lower,
        help="joint order of a positions file without joint names (.csv without "
        "a header, .npy): kinect (v2, 25), blazepose (33 world landmarks), "
        "coco17, body25 (OpenPose)",
    )
    p.add_argument(
        "--markers",
        metavar="MAP.toml",
        help="a marker set of your own for .c3d/.trc markers no built-in set maps: "
        "TOML of joint = marker or [markers] (streamseg info FILE prints a "
        "template; docs/guide/formats.md)",
    )
    p.add_argument(
        "--strict",
        action="store_true",
        help="refuse a truncated recording (default: keep its good frames and "
        "say how many were dropped)",
    )
    p.add_argument(
        "--gap-fill",
        type=_seconds,
        default=FILL_S,
        metavar="S",
        help="fill gaps (missing joint positions) up to S seconds by "
        "interpolation; longer gaps are skipped by the detectors and "
        f"reported (default {FILL_S:g}; 0: fill none)",
    )
    if write_events:
        p.add_argument(
            "--write-events",
            metavar="OUT.c3d",
            help="with a .c3d input: write a copy with the cuts/segments as C3D "
            "events (Vicon Nexus and Mokka show them)",
        )


def is_positions_table(path, joints: str | None = None) -> bool:
    """Whether a ``.npy``/``.csv`` holds joint positions rather than a feature matrix: a
    header naming joint coordinates, a 3-D array, or ``--joints`` given."""
    path = Path(path)
    if joints:
        return True
    if path.suffix.lower() == ".npy":
        import numpy as np

        try:
            return np.load(path, mmap_mode="r", allow_pickle=False).ndim == 3
        except (ValueError, OSError, EOFError):
            return False  # the matrix reader says what is wrong
    try:
        with open(path, encoding="utf-8-sig", errors="replace") as fh:
            first = next((line for line in fh if line.strip()), "")
    except OSError:
        return False
    from streamseg.io.positions import header_joints

    sep = ";" if first.count(";") > first.count(",") else ","
    return header_joints(first.split(sep)) is not None


def is_matrix(args) -> bool:
    """Whether ``args.file`` is a feature matrix (``.npy``/``.csv`` that are not positions)."""
    file = str(args.file)
    return Path(file).suffix.lower() in MATRIX_SUFFIXES and not is_positions_table(
        file, getattr(args, "joints", None)
    )


def read_recording(args):
    """Read ``args.file`` as every command does: report truncation and gaps as warnings and
    keep the gaps for the JSON (``args.gaps``)."""
    from streamseg.io import read

    joints = getattr(args, "joints", None)
    markers = getattr(args, "markers", None)
    rec = read(
        args.file,
        getattr(args, "skeleton", None),
        fps=getattr(args, "fps", None),
        joints=joints,
        lenient=not getattr(args, "strict", False),
        gap_fill=getattr(args, "gap_fill", FILL_S),
        markers=markers,
    )
    if markers and "markers" not in rec.metadata:
        warn(
            args,
            f"--markers {markers} does nothing for {Path(str(args.file)).name}: it "
            "maps the markers of .c3d and .trc files",
        )
    for w in rec.metadata.get("warnings", []):
        warn(args, w)
    if joints and not rec.metadata.get("joints"):
        warn(
            args,
            f"--joints {joints} does nothing for {Path(str(args.file)).name}: the file "
            "names its joints",
        )
    gaps = rec.metadata.get("gaps", [])
    args.gaps = [
        {"start": s, "end": e, "start_s": round(s / rec.fps, 4), "end_s": round(e / rec.fps, 4)}
        for s, e in gaps
    ]
    args.filled_frames = int(rec.metadata.get("filled_frames", 0))
    if gaps:
        shown = ", ".join(f"{s}-{e - 1}" for s, e in gaps[:5]) + (" ..." if len(gaps) > 5 else "")
        total = sum(e - s for s, e in gaps)
        fill = rec.metadata.get("gap_fill_s", FILL_S)
        warn(
            args,
            f"{Path(str(args.file)).name}: {len(gaps)} gap{'s' if len(gaps) > 1 else ''}"
            f" without the joint positions the features use, longer than {fill:g} s "
            f"or at an end of the take (frames {shown}; {total} frames, "
            f"{total / rec.fps:.2f} s in all): skipped by the detectors (--gap-fill S "
            "fills longer gaps)",
        )
    return rec


def check_write_events(args) -> None:
    """Fail before the work on a ``--write-events`` that cannot be done."""
    out = getattr(args, "write_events", None)
    if not out:
        return
    if Path(str(args.file)).suffix.lower() != ".c3d":
        raise ParameterError(
            f"--write-events needs a .c3d input (events are written into a "
            f"copy of it); {Path(str(args.file)).name} is not one"
        )
    if Path(out).suffix.lower() != ".c3d":
        raise ParameterError(f"--write-events {out}: expected a .c3d file name")
    folder = Path(out).parent if str(Path(out).parent) else Path(".")
    if not folder.is_dir() or not os.access(folder, os.W_OK):
        raise ParameterError(
            f"--write-events {out}: folder {folder} does not exist or is not writable"
        )


def write_events(args, result: dict) -> None:
    """Write ``result``'s segments as events into a copy of the C3D input."""
    from streamseg.io.c3d import write_events as write

    n = write(
        args.file,
        args.write_events,
        result["segments"],
        result["fps"],
        method=result.get("method", "streamseg"),
    )
    result["events_file"] = str(args.write_events)
    result["events_written"] = n
