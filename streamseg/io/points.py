"""Named points as a recording: joint positions with the trunk points a pose model lacks
added, and the markers of a C3D or TRC mapped to joints by a marker set."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from streamseg.exceptions import RecordingError
from streamseg.recording import Recording, Skeleton
from streamseg.skeleton.joint_sets import complete


def positions_recording(
    path, names, pos, rate: float, units: str, up: str, meta: dict, *, detect: bool = False
) -> Recording:
    """A recording of named joint positions, the trunk points a pose model lacks added
    (:func:`streamseg.skeleton.joint_sets.complete`); ``detect``: the up axis is the one the
    body stands along (:func:`streamseg.skeleton.bones.upright_axis`), ``up`` when no axis is
    clear."""
    names, pos = complete(names, pos)
    if detect:
        from streamseg.skeleton.bones import upright_axis

        up = upright_axis(pos, names) or up
    n = len(names)
    skel = Skeleton(tuple(names), np.full(n, -1, dtype=np.int64), np.zeros((n, 3)), units, up)
    return Recording(float(rate), skel, np.ascontiguousarray(pos), None, str(path), meta)


def points_recording(
    path,
    xyz: np.ndarray,
    names,
    rate: float,
    units: str,
    meta: dict,
    *,
    up: str = "y",
    noun: str = "points",
    marker_map=None,
) -> Recording:
    """Named 3-D points (C3D, TRC) as a recording.

    Markers of a set streamseg maps become its joints (joint centres where the set defines
    them, :mod:`streamseg.skeleton.marker_sets`); otherwise the names must be joints of a
    skeleton streamseg knows (:data:`streamseg.skeleton.names.POINTS`: a skeleton exported by
    an inertial suit, keypoints triangulated from video ...), a pose model's trunk added.

    Parameters
    ----------
    xyz : ndarray, shape (n_frames, n_points, 3)
        NaN where a point is missing.
    up : str
        The up axis when the body does not show one (it stands along an axis otherwise).
    noun : str
        What the file calls its points, for the error.
    marker_map : MarkerSet or path, optional
        The user's own marker set (``--markers MAP.toml``,
        :func:`streamseg.skeleton.marker_map.load_marker_map`), used instead of the built-in
        ones: every marker it names must be in the file.

    Raises
    ------
    RecordingError
        Neither a marker set nor a skeleton names the points: the markers each joint lacks.
    """
    from streamseg.exceptions import SkeletonError
    from streamseg.skeleton.bones import upright_axis
    from streamseg.skeleton.marker_sets import JOINTS, PARENTS, best_set, joint_positions
    from streamseg.skeleton.names import POINTS, resolve

    if marker_map is not None:
        from streamseg.skeleton.marker_map import load_marker_map
        from streamseg.skeleton.marker_sets import plan

        mset = (
            marker_map if not isinstance(marker_map, (str, Path)) else load_marker_map(marker_map)
        )
        chosen, missing = plan(mset, names)
        if missing and mset.pairs:  # a pair's marker the file leaves out: lost in every frame
            from streamseg.skeleton.marker_fill import with_absent_pair_markers

            more, wider = with_absent_pair_markers(names, xyz, (mset,))
            again = plan(mset, more) if len(more) > len(names) else (None, missing)
            if not again[1]:
                names, xyz = more, wider
                chosen, missing = again
        if missing:
            lack = "; ".join(f"{p} ({' '.join(m)})" for p, m in missing.items())
            raise RecordingError(
                path,
                None,
                f"{len(names)} {noun} without the markers {mset.name} names, per joint: {lack}",
                f"the file's marker names in the map (streamseg info {Path(path).name} lists them)",
            )
    else:
        mset, chosen, missing = best_set(names)
        if missing:  # a pelvis marker the file leaves out altogether: lost in every frame
            from streamseg.skeleton.marker_fill import with_absent_pair_markers

            more, wider = with_absent_pair_markers(names, xyz)
            if len(more) > len(names):
                again = best_set(more)
                if not again[2]:
                    names, xyz = more, wider
                    mset, chosen, missing = again
    if not missing:
        from streamseg.skeleton.marker_fill import fill_from_clusters

        xyz, notes = fill_from_clusters(xyz, names, mset.clusters, mset.pairs)
        from streamseg.io.gaps import fill_frames

        joints = joint_positions(xyz, names, chosen, mset, min_run=fill_frames(rate) + 1)
        gone = [p for j, p in enumerate(JOINTS) if not np.isfinite(joints[:, j]).any()]
        if gone:
            notes.append(
                f"no marker places {', '.join(gone)} in any frame: left out, the "
                "other body parts serve"
            )
        meta = {
            **meta,
            "warnings": list(meta.get("warnings", []))
            + [f"{Path(str(path)).name}: {n}" for n in notes],
        }
        skel = Skeleton(
            JOINTS,
            np.array(PARENTS),
            np.zeros((len(JOINTS), 3)),
            units,
            upright_axis(joints, JOINTS) or up,
        )
        return Recording(rate, skel, joints, None, str(path), {**meta, "marker_set": mset.name})
    try:
        resolve(complete(names, xyz[:1])[0], tuple(POINTS), POINTS)
    except SkeletonError:
        lack = "; ".join(f"{p} ({' '.join(m)})" for p, m in missing.items())
        raise RecordingError(
            path,
            None,
            f"{len(names)} {noun} ({', '.join(names[:12])}{' ...' if len(names) > 12 else ''})",
            f"a marker set streamseg maps; closest: {mset.name} "
            f"({mset.description}), which lacks, per joint: {lack}; or the "
            "joint names of a skeleton streamseg knows (docs/guide/formats.md); "
            "or a map of your own: --markers MAP.toml (streamseg info "
            f"{Path(path).name} prints a template)",
        ) from None
    return positions_recording(path, names, xyz, rate, units, up, meta, detect=True)
