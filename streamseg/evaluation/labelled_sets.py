"""The labelled recordings of the bundled data, in named sets: what ``eval --all data`` scores.

Five sets (``docs/results.md`` reports each):

- ``cmu``: CMU 86_01 and the exercise routines 14_14, 14_20 (label CSVs beside them);
- ``cmu02``: two sequences joined from CMU subject 02 single-action trials
  (:data:`~streamseg.evaluation.datasets.CMU02_SEQUENCES`);
- ``hdm``: nine sequences joined from HDM05 clips
  (:func:`~streamseg.evaluation.datasets.hdm05_action_plans`);
- ``fresh``: nine more HDM05 joins from clips no ``hdm`` join uses;
- ``fresh2``: four more from the clips left after those.

The joined sequences' true cuts are their joins, abrupt by construction; each part is labelled
with its action (a CMU 02 trial's label, an HDM05 class), so labelling methods are scored on
them too.
"""

from __future__ import annotations

from pathlib import Path

from streamseg.evaluation.corpus import LabelledRecording, discover
from streamseg.evaluation.datasets import (
    CMU02_SEQUENCES,
    CMU02_TRIAL_ACTIONS,
    cmu02_sequence,
    fresh2_action_plans,
    fresh_action_plans,
    hdm05_action_plans,
    hdm05_sequence,
)
from streamseg.evaluation.labels import LabelSegment
from streamseg.exceptions import ParameterError

#: every set, in the order of the tables
SETS = ("cmu", "cmu02", "hdm", "fresh", "fresh2")
_JOINED_NOTE = "joined clips: the joins are abrupt"


def has_bundled_layout(folder) -> bool:
    """Whether ``folder`` holds the clips the joined sets are built from (as ``data/`` does)."""
    root = Path(folder)
    return (root / "cmu02" / "02.asf").is_file() and (root / "hdm05_reps" / "clips.csv").is_file()


def _segments(bounds, labels) -> list[LabelSegment]:
    """Labelled segments ``[bounds[i], bounds[i+1])``; no acceptance window beyond the join."""
    return [LabelSegment(a, b, lab, b, b) for a, b, lab in zip(bounds[:-1], bounds[1:], labels)]


def _cmu02(folder) -> list[LabelledRecording]:
    out = []
    for name, trials in CMU02_SEQUENCES.items():
        rec, cuts = cmu02_sequence(folder, trials)
        labels = [CMU02_TRIAL_ACTIONS[t][0] for t in trials]
        out.append(
            LabelledRecording(
                name, rec, _segments([0, *cuts, rec.n_frames], labels), _JOINED_NOTE, "cmu02"
            )
        )
    return out


def _hdm(folder, plans: dict, group: str) -> list[LabelledRecording]:
    out = []
    for name, (actor, parts) in plans.items():
        rec, cuts = hdm05_sequence(folder, actor, parts)
        labels = [cls for cls, _paths in parts]
        out.append(
            LabelledRecording(
                name, rec, _segments([0, *cuts, rec.n_frames], labels), _JOINED_NOTE, group
            )
        )
    return out


def labelled_sets(folder, sets=None, skeleton=None, markers=None) -> list[LabelledRecording]:
    """Every labelled recording under ``folder`` with its set name (``group``).

    Recordings named by a label CSV (:func:`~streamseg.evaluation.corpus.discover`) come
    first, in set ``cmu`` when they are the bundled CMU takes and ``files`` otherwise; when
    ``folder`` has the bundled layout (:func:`has_bundled_layout`), the joined sets follow.

    Parameters
    ----------
    folder : str or Path
    sets : iterable of str or None
        Keep only these sets (names of :data:`SETS`, or ``files``); None: all.
    skeleton : str or Path or None
        ASF for AMCs whose folder has none. With the bundled layout the CMU exercise takes,
        which have no ASF of their own, default to ``cmu86/86.asf`` (the standard CMU
        layout).
    markers : str or Path or MarkerSet or None
        A marker map for the C3D and TRC recordings
        (:func:`~streamseg.evaluation.corpus.discover`).

    Raises
    ------
    ParameterError
        For an unknown set name, or a joined set asked of a folder without the clips.
    """
    wanted = None if sets is None else list(dict.fromkeys(sets))
    known = (*SETS, "files")
    for name in wanted or ():
        if name not in known:
            raise ParameterError(f"unknown set {name!r}: expected one of {', '.join(known)}")
    bundled = has_bundled_layout(folder)
    if skeleton is None and bundled:
        skeleton = Path(folder) / "cmu86" / "86.asf"
    out = []
    if wanted is None or {"cmu", "files"} & set(wanted):
        for item in discover(folder, skeleton=skeleton, markers=markers):
            item.group = "cmu" if bundled and item.name in ("86_01", "14_14", "14_20") else "files"
            out.append(item)
    joined = [s for s in SETS[1:] if wanted is None or s in wanted]
    if joined and not bundled:
        if wanted is not None:
            raise ParameterError(
                f"set {joined[0]} is joined from the bundled clips "
                f"(cmu02/, hdm05_reps/), which {folder} does not hold"
            )
        joined = []
    if "cmu02" in joined:
        out += _cmu02(folder)
    if {"hdm", "fresh", "fresh2"} & set(joined):
        plans = {
            "hdm": hdm05_action_plans,
            "fresh": fresh_action_plans,
            "fresh2": fresh2_action_plans,
        }
        for group in ("hdm", "fresh", "fresh2"):
            if group in joined:
                out += _hdm(folder, plans[group](folder), group)
    if wanted is not None:
        out = [item for item in out if item.group in wanted]
    return out
