"""A marker set of the user's own, from a TOML file: ``--markers MAP.toml``.

Each key is one of the canonical joints the features need
(:data:`streamseg.skeleton.marker_sets.JOINTS`), each value the marker that stands for it or
a list of markers whose mean it is (a joint centre between a lateral and a medial marker, a
cluster on the segment)::

    # streamseg marker map: joint = marker, or [markers] (their mean)
    pelvis = ["Daphnee:ASISl", "Daphnee:ASISr", "Daphnee:PSISl", "Daphnee:PSISr"]
    spine = "Daphnee:T10"
    l_knee = ["Daphnee:KNEl", "Daphnee:KNEml"]
    ...

Namespaces (``Subject:``) may be left out, case does not matter (as for the built-in sets).
Every joint is needed: the bone angles use hips, knees, ankles, shoulders, elbows, wrists and
the trunk. ``streamseg info FILE`` lists a file's markers and prints a template of this file.

Two optional keys say how lost markers are placed (as the built-in sets do)::

    # markers on one rigid segment: one lost for a stretch is placed from three others seen
    clusters = [["Daphnee:T10", "Daphnee:C7", "Daphnee:CLAV", "Daphnee:STRN"]]
    # two left/right pairs of one segment: a marker of one pair lost in every frame (or
    # absent from the file) is its twin mirrored across the other pair's mid-plane
    pairs = [[["Daphnee:ASISl", "Daphnee:ASISr"], ["Daphnee:PSISl", "Daphnee:PSISr"]]]

A joint made of four markers or more is a cluster without saying so.
"""

from __future__ import annotations

from pathlib import Path

from streamseg.exceptions import ParameterError
from streamseg.skeleton.marker_sets import JOINTS, MarkerSet
from streamseg.skeleton.names import bare


def load_marker_map(path) -> MarkerSet:
    """The :class:`MarkerSet` a TOML marker map describes (see the module docstring).

    Raises
    ------
    ParameterError
        The file is missing or not TOML, names a joint that is not one of ``JOINTS``, gives a
        value that is not a marker name or a list of them, or leaves a joint out.
    """
    from streamseg.config._toml import read_toml

    doc = read_toml(path, f"--markers {path}")
    clusters = _clusters(path, doc.pop("clusters", []))
    pairs = _pairs(path, doc.pop("pairs", []))
    unknown = sorted(set(doc) - set(JOINTS))
    if unknown:
        raise ParameterError(
            f"--markers {path}: {', '.join(unknown)} is not a joint of the "
            f"map; expected keys among {', '.join(JOINTS)}"
        )
    missing = [j for j in JOINTS if j not in doc]
    if missing:
        raise ParameterError(
            f"--markers {path}: no markers for {', '.join(missing)}: every "
            f"joint of {', '.join(JOINTS)} needs a marker or a list of them"
        )
    points = {}
    for joint in JOINTS:
        value = doc[joint]
        names = [value] if isinstance(value, str) else value
        if not (
            isinstance(names, list)
            and names
            and all(isinstance(n, str) and bare(n.strip()) for n in names)
        ):
            raise ParameterError(
                f"--markers {path}: {joint} = {value!r}: expected a marker "
                "name or a list of marker names (their mean)"
            )
        points[joint] = (tuple(bare(n.strip()) for n in names),)
    for (alt,) in points.values():  # a joint of four markers or more: a segment's cluster
        if len(alt) >= 4 and alt not in clusters:
            clusters.append(alt)
    return MarkerSet(
        f"{Path(path).name} (--markers)",
        f"the marker map {path}",
        points,
        clusters=tuple(clusters),
        pairs=tuple(pairs),
    )


def _names(value) -> bool:
    return isinstance(value, list) and all(isinstance(n, str) and bare(n.strip()) for n in value)


def _clusters(path, value) -> list:
    if not (isinstance(value, list) and all(_names(c) and len(c) >= 4 for c in value)):
        raise ParameterError(
            f"--markers {path}: clusters = {value!r}: expected a list of lists of four "
            "marker names or more (the markers of one rigid segment)"
        )
    return [tuple(bare(n.strip()) for n in c) for c in value]


def _pairs(path, value) -> list:
    ok = isinstance(value, list) and all(
        isinstance(p, list) and len(p) == 2 and all(_names(q) and len(q) == 2 for q in p)
        for p in value
    )
    if not ok:
        raise ParameterError(
            f"--markers {path}: pairs = {value!r}: expected a list of [[left, right], "
            "[left, right]] marker names (two left/right pairs of one segment)"
        )
    return [tuple(tuple(bare(n.strip()) for n in q) for q in p) for p in value]


def template(markers) -> str:
    """A marker map to fill in for a file with these ``markers``: every joint, with the
    file's markers listed in a comment."""
    shown = ", ".join(markers[:60]) + (" ..." if len(markers) > 60 else "")
    lines = [
        "# streamseg marker map (--markers FILE.toml): joint = marker, or [markers] (their mean)",
        f"# this file's markers: {shown}",
    ]
    lines += [f'{j} = ["?"]' for j in JOINTS]
    return "\n".join(lines)


def stream_markers(mset: MarkerSet, names) -> tuple:
    """A live stream's marker names, with a pair's marker it leaves out added last when the
    map then has every joint (as the readers add it: lost in every frame, mirrored from its
    twin; :class:`streamseg.skeleton.marker_fill.LiveMarkerFill` adds its NaN column)."""
    from streamseg.skeleton.marker_sets import plan

    names = tuple(names)
    if mset.pairs and plan(mset, names)[1]:
        import numpy as np

        from streamseg.skeleton.marker_fill import with_absent_pair_markers

        more = tuple(with_absent_pair_markers(names, np.zeros((0, len(names), 3)), (mset,))[0])
        if len(more) > len(names) and not plan(mset, more)[1]:
            return more
    return names


def marker_columns(mset: MarkerSet, names):
    """``(columns, missing)`` of a marker map for a live stream's joint names (the daemon,
    the LSL input): ``columns[j]``, the indices of the names (:func:`stream_markers`: a
    pair's absent marker added last) whose mean is joint ``j`` of :data:`JOINTS` (None when
    some are absent), and ``missing``, joint -> the markers of the map the names lack."""
    from streamseg.skeleton.marker_sets import plan

    names = stream_markers(mset, names)
    chosen, missing = plan(mset, names)
    if missing:
        return None, missing
    index = {}
    for i, name in enumerate(names):
        index.setdefault(bare(str(name).strip()).upper(), i)
    return tuple(tuple(index[m.upper()] for m in chosen[j]) for j in JOINTS), {}


def columns_for(mset: MarkerSet, names):
    """The columns of a marker map for a live stream's joint names when they hold its
    markers (:func:`marker_columns`); None when they do not but name a skeleton streamseg
    knows (the stream is used as it is).

    Raises
    ------
    SkeletonError
        The names are neither: what the skeleton lacks and the markers the map lacks.
    """
    from streamseg.exceptions import SkeletonError
    from streamseg.skeleton.bones import bone_point_indices

    columns, missing = marker_columns(mset, names)
    if columns is not None:
        return columns
    try:
        bone_point_indices(tuple(names))
    except SkeletonError as err:
        lack = "; ".join(f"{p} ({' '.join(m)})" for p, m in list(missing.items())[:6])
        raise SkeletonError(
            f"{err}; nor are they the markers of {mset.name}, which lacks, per joint: {lack}"
        ) from None
    return None


def joints_of_markers(positions, columns):
    """The joints of :data:`JOINTS` from marker positions ``(n, M, 3)``: each the mean of its
    ``columns`` (:func:`marker_columns`); NaN where one of them is. Returns ``(n, 16, 3)``."""
    import numpy as np

    positions = np.asarray(positions, dtype=np.float64)
    out = np.empty((positions.shape[0], len(columns), 3))
    for j, cols in enumerate(columns):
        out[:, j] = (
            positions[:, cols[0]] if len(cols) == 1 else positions[:, list(cols)].mean(axis=1)
        )
    return out
