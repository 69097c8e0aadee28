"""``streamseg info``: what a recording holds, and the range of each feature."""

from __future__ import annotations

import numpy as np

from streamseg.io import read
from streamseg.skeleton import ANGLE_NAMES, bone_angles, quaternion_features
from streamseg.skeleton.bones import INCLINATION_NAMES
from streamseg.skeleton.quaternions import ACA_SEGMENTS


def _table(title, names, values, unit) -> list[str]:
    lines = [f"{title}:", f"  {'feature':<22}{'min':>9}{'median':>9}{'max':>9}  ({unit})"]
    with np.errstate(invalid="ignore"):
        lo, med, hi = np.nanmin(values, 0), np.nanmedian(values, 0), np.nanmax(values, 0)
    for i, name in enumerate(names):
        lines.append(f"  {name:<22}{lo[i]:9.3f}{med[i]:9.3f}{hi[i]:9.3f}")
    return lines


def _matrix_info(path, fps) -> str:
    from streamseg.io.matrix import read_matrix

    m = read_matrix(path)
    out = [
        f"file:      {path}",
        "format:    feature matrix (rows = frames)",
        f"frames:    {m.shape[0]}",
        f"columns:   {m.shape[1]}",
    ]
    if fps:
        out += [f"fps:       {fps:g}", f"duration:  {m.shape[0] / fps:.2f} s"]
    else:
        out.append("fps:       not stored in a matrix (segment/eval take --fps)")
    out.append(f"NaN rows:  {int((~np.isfinite(m)).any(axis=1).sum())}")
    if m.shape[1] in (8, 17):
        out.append(
            f"looks like: the cut detector's {m.shape[1]} bone features "
            f"(--inclinations {'on' if m.shape[1] == 17 else 'off'})"
        )
    out += _table("columns", [f"column {i}" for i in range(m.shape[1])], m, "as stored")
    return "\n".join(out)


def info(path, skeleton=None, fps=None, joints=None, gap_fill=None, markers=None) -> str:
    """A readable summary of ``path``: size, rate, joints and feature ranges (a recording),
    or rows, columns and column ranges (a feature matrix ``.npy``/``.csv``); for a file that
    cannot be segmented as it stands (markers no set maps, an AMC without its skeleton) what
    it holds and what segmenting it would need (:mod:`streamseg.commands.info_raw`)."""
    from pathlib import Path

    from streamseg.commands.inputs import MATRIX_SUFFIXES, is_positions_table
    from streamseg.exceptions import RecordingError, SkeletonError
    from streamseg.io.gaps import FILL_S

    if Path(path).suffix.lower() in MATRIX_SUFFIXES and not is_positions_table(path, joints):
        return _matrix_info(path, fps)
    try:
        rec = read(
            path,
            skeleton,
            fps=fps,
            lenient=True,
            joints=joints,
            gap_fill=FILL_S if gap_fill is None else gap_fill,
            markers=markers,
        )
    except (RecordingError, SkeletonError) as err:
        from streamseg.commands.info_raw import describe

        said = describe(path, err) if Path(path).is_file() else None
        if said is None:
            raise
        return said
    n_nan = int(np.isnan(rec.positions).any(axis=(1, 2)).sum())
    out = [
        f"file:      {path}"
        + (
            f" (converted from {rec.source})" if rec.source and str(rec.source) != str(path) else ""
        ),
        f"format:    {rec.metadata.get('format')}",
        f"frames:    {rec.n_frames}",
        f"fps:       {rec.fps:g}",
        f"duration:  {rec.duration:.2f} s",
        f"joints:    {rec.skeleton.n_joints} ({', '.join(rec.skeleton.names)})",
        f"units:     {rec.skeleton.units}",
        f"NaN frames: {n_nan}",
    ]
    if rec.metadata.get("marker_set"):
        out.append(
            f"markers:   {len(rec.metadata['markers'])}, mapped by the "
            f"{rec.metadata['marker_set']} set; up axis {rec.skeleton.up}"
        )
    if rec.metadata.get("filled_frames") or rec.metadata.get("gaps"):
        gaps = rec.metadata.get("gaps", [])
        out.append(
            f"gaps:      {rec.metadata.get('filled_frames', 0)} frames filled by "
            f"interpolation; {len(gaps)} longer gaps ("
            f"{sum(e - s for s, e in gaps)} frames) the detectors skip"
        )
    out += [f"warning:   {w}" for w in rec.metadata.get("warnings", [])]
    feats = bone_angles(rec.positions, rec.skeleton, inclinations=True)
    out += _table("bone angles (Xing et al. Table 2)", ANGLE_NAMES, feats[:, :8], "rad")
    out += _table(
        f"bone inclinations from the up axis ({rec.skeleton.up})",
        INCLINATION_NAMES,
        feats[:, 8:],
        "rad",
    )
    if rec.rotations is not None:
        q = quaternion_features(rec).reshape(rec.n_frames, -1, 4)
        # Rotation angle of each joint away from its rest pose: 2 acos |w|.
        angle = 2 * np.arccos(np.clip(np.abs(q[..., 0]), 0, 1))
        out += _table("joint rotation from rest (ACA joints)", ACA_SEGMENTS, angle, "rad")
    return "\n".join(out)


def add_arguments(parser) -> None:
    from streamseg.commands.args import add_input_arguments

    add_input_arguments(parser)


def run(args) -> int:
    print(
        info(
            args.file,
            skeleton=args.skeleton,
            fps=args.fps,
            joints=args.joints,
            gap_fill=args.gap_fill,
            markers=args.markers,
        )
    )
    return 0
