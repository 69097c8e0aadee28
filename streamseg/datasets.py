"""Evaluation sequences built from real clips with known cut points.

Concatenating single-action clips (e.g. CMU subject 02: walk, run, jump, punch) gives real
multi-action sequences whose true cuts are the joins. The joins are abrupt (no natural
transition), which benchmarks that use them must say.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from streamseg.exceptions import ParameterError

#: Trial-level labels of the CMU subject 02 trials in data/cmu02 (data/README.md), as the
#: list of actions each label names.
CMU02_TRIAL_ACTIONS = {
    "01": ("walk",), "02": ("walk",), "03": ("run/jog",), "04": ("jump", "balance"),
    "05": ("punch/strike",), "06": ("bend", "scoop", "rise"), "07": ("swordplay",),
    "08": ("swordplay",), "09": ("swordplay",), "10": ("wash self",),
}

#: A trial may be joined into an evaluation sequence only when its label names ONE action and
#: it lasts at least this long (decided from the labels, before any result): the true cuts of
#: a joined sequence are only its joins, so a clip holding several actions (04 jump + balance,
#: 06 bend-scoop-rise) has real changes that would count as false positives, and a clip
#: shorter than about one LOF window plus margin (03 run, 1.4 s; 02 walk, 2.48 s) is no
#: segment a window-based method can see. Eligible: 01 walk (2.9 s), 05 punch/strike
#: (15.5 s), 07-09 swordplay, 10 wash self (22.0 s).
CMU02_MIN_SECONDS = 2.5

#: Sequences joined from eligible trials: each action once, two different orders (the
#: README's order, and another order with another swordplay trial). Their true cuts are the
#: joins, abrupt by construction.
CMU02_SEQUENCES = {
    "02_walk_punch_sword_wash": ("01", "05", "07", "10"),
    "02_wash_sword_walk_punch": ("10", "08", "01", "05"),
}

#: The earlier sequences, kept for reference only: they break the rule above (03 is 1.4 s,
#: shorter than a window; 04 and 06 hold two and three actions), so their joins are not the
#: only true changes. Benchmarks report them separately and keep them out of means.
CMU02_MULTI_ACTION_SEQUENCES = {
    "02_walk_run_jump_punch": ("01", "03", "04", "05"),
    "02_punch_bend_walk_jump": ("05", "06", "01", "04"),
}


def concatenate(recordings) -> tuple:
    """Join recordings end to end.

    Parameters
    ----------
    recordings : sequence of Recording
        Same skeleton (joint names and up axis) and frame rate.

    Returns
    -------
    recording : Recording
        Positions (and rotations when every part has them) stacked in time.
    cuts : list of int
        0-based first frame of every part after the first (the joins).
    """
    recs = list(recordings)
    if not recs:
        raise ParameterError("concatenate() needs at least one recording")
    first = recs[0]
    for r in recs[1:]:
        if tuple(r.skeleton.names) != tuple(first.skeleton.names) or r.fps != first.fps \
                or r.skeleton.up != first.skeleton.up:
            raise ParameterError(
                f"cannot join {r.source or 'a recording'} to {first.source or 'the first'}: "
                "skeleton joint names, up axis and fps must match (read them with the same "
                "skeleton)")
    positions = np.concatenate([r.positions for r in recs], axis=0)
    rotations = None
    if all(r.rotations is not None for r in recs):
        rotations = np.concatenate([r.rotations for r in recs], axis=0)
    lengths = np.array([r.n_frames for r in recs])
    cuts = [int(c) for c in np.cumsum(lengths)[:-1]]
    source = " + ".join(str(r.source) for r in recs)
    joined = replace(first, positions=positions, rotations=rotations, source=source,
                     metadata={**first.metadata, "concatenated": [str(r.source) for r in recs],
                               "cuts": cuts})
    return joined, cuts


def cmu02_sequence(data_dir, trials) -> tuple:
    """Read CMU subject 02 trials (e.g. ``("01", "03")``) from ``data_dir/cmu02`` and join them.

    Returns
    -------
    recording : Recording
    cuts : list of int
        The joins (true cuts).
    """
    from streamseg.io import read

    root = Path(data_dir) / "cmu02"
    asf = root / "02.asf"
    return concatenate([read(root / f"02_{t}.amc.gz", skeleton=asf) for t in trials])
