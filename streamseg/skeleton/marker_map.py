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
    unknown = sorted(set(doc) - set(JOINTS))
    if unknown:
        raise ParameterError(f"--markers {path}: {', '.join(unknown)} is not a joint of the "
                             f"map; expected keys among {', '.join(JOINTS)}")
    missing = [j for j in JOINTS if j not in doc]
    if missing:
        raise ParameterError(f"--markers {path}: no markers for {', '.join(missing)}: every "
                             f"joint of {', '.join(JOINTS)} needs a marker or a list of them")
    points = {}
    for joint in JOINTS:
        value = doc[joint]
        names = [value] if isinstance(value, str) else value
        if not (isinstance(names, list) and names
                and all(isinstance(n, str) and bare(n.strip()) for n in names)):
            raise ParameterError(f"--markers {path}: {joint} = {value!r}: expected a marker "
                                 "name or a list of marker names (their mean)")
        points[joint] = (tuple(bare(n.strip()) for n in names),)
    return MarkerSet(f"{Path(path).name} (--markers)", f"the marker map {path}", points)


def template(markers) -> str:
    """A marker map to fill in for a file with these ``markers``: every joint, with the
    file's markers listed in a comment."""
    shown = ", ".join(markers[:60]) + (" ..." if len(markers) > 60 else "")
    lines = ["# streamseg marker map (--markers FILE.toml): joint = marker, or [markers] "
             "(their mean)", f"# this file's markers: {shown}"]
    lines += [f'{j} = ["?"]' for j in JOINTS]
    return "\n".join(lines)
