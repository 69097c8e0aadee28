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
    "01": ("walk",),
    "02": ("walk",),
    "03": ("run/jog",),
    "04": ("jump", "balance"),
    "05": ("punch/strike",),
    "06": ("bend", "scoop", "rise"),
    "07": ("swordplay",),
    "08": ("swordplay",),
    "09": ("swordplay",),
    "10": ("wash self",),
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
        if (
            tuple(r.skeleton.names) != tuple(first.skeleton.names)
            or r.fps != first.fps
            or r.skeleton.up != first.skeleton.up
        ):
            raise ParameterError(
                f"cannot join {r.source or 'a recording'} to {first.source or 'the first'}: "
                "skeleton joint names, up axis and fps must match (read them with the same "
                "skeleton)"
            )
    positions = np.concatenate([r.positions for r in recs], axis=0)
    rotations = None
    if all(r.rotations is not None for r in recs):
        rotations = np.concatenate([r.rotations for r in recs], axis=0)
    lengths = np.array([r.n_frames for r in recs])
    cuts = [int(c) for c in np.cumsum(lengths)[:-1]]
    source = " + ".join(str(r.source) for r in recs)
    joined = replace(
        first,
        positions=positions,
        rotations=rotations,
        source=source,
        metadata={**first.metadata, "concatenated": [str(r.source) for r in recs], "cuts": cuts},
    )
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


#: HDM05 classes whose clips hold exactly one repetition each (data/hdm05_reps/README.md).
HDM05_REPETITIVE = (
    "squat1Reps",
    "elbowToKnee1RepsLelbowStart",
    "rotateArmsBothBackward1Reps",
    "kickLFront1Reps",
    "hopBothLegs1hops",
)
#: HDM05 classes whose clips hold one whole action each.
HDM05_ACTIONS = (
    "depositFloorR",
    "grabHighR",
    "lieDownFloor",
    "throwBasketball",
    "sneak2StepsLStart",
    "jogLeftCircle4StepsRstart",
)
HDM05_ACTORS = ("bd", "bk", "dg")
#: Repetitions a repetitive class contributes to an action sequence: one set of this many.
HDM05_SET_REPS = 3


def hdm05_clips(data_dir) -> dict:
    """``(actor, class) -> [clip path, ...]`` in take order, from ``hdm05_reps/clips.csv``."""
    import csv

    root = Path(data_dir) / "hdm05_reps"
    out: dict = {}
    with open(root / "clips.csv", newline="") as fh:
        for row in csv.DictReader(fh):
            out.setdefault((row["actor"], row["class"]), []).append(
                root / row["class"] / (row["file"] + ".gz")
            )
    return out


def _clips_left(clips, actor, cls, used) -> bool:
    """Whether ``actor`` has enough unused ``cls`` clips for one more part."""
    need = HDM05_SET_REPS if cls in HDM05_REPETITIVE else 1
    return len(clips.get((actor, cls), [])) - used[cls] >= need


def hdm05_action_plans(
    data_dir,
    per_actor: int = 3,
    n_classes: int = 5,
    seed: int = 0,
    exclude=None,
    prefix: str = "hdm",
) -> dict:
    """Which clips make each HDM05 action sequence, decided before any result is seen.

    Per actor, ``per_actor`` sequences of ``n_classes`` distinct classes in random order (at
    least one repetitive and one whole-action class each); a whole-action class is one clip, a
    repetitive class a set of :data:`HDM05_SET_REPS` consecutive takes. No clip is used twice.

    Parameters
    ----------
    exclude : dict or None
        Plans (this function's output) whose clips are not used again: fresh sequences for a
        held-out test (:func:`fresh_action_plans`).
    prefix : str
        Start of the sequence names.

    Returns
    -------
    dict
        ``name -> (actor, [(class, [path, ...]), ...])``, names ``<prefix>_<actor>_<i>``.
    """
    clips = hdm05_clips(data_dir)
    if exclude:
        taken = {p for _actor, parts in exclude.values() for _cls, paths in parts for p in paths}
        clips = {key: [p for p in paths if p not in taken] for key, paths in clips.items()}
    rng = np.random.default_rng(seed)
    plans = {}
    for actor in HDM05_ACTORS:
        used = {c: 0 for c in HDM05_REPETITIVE + HDM05_ACTIONS}
        for i in range(per_actor):
            rep = [c for c in HDM05_REPETITIVE if _clips_left(clips, actor, c, used)]
            act = [c for c in HDM05_ACTIONS if _clips_left(clips, actor, c, used)]
            if not rep or not act or len(rep) + len(act) < n_classes:
                raise ParameterError(
                    f"hdm05_action_plans: actor {actor} has too few clips "
                    f"for {per_actor} sequences of {n_classes} classes"
                )
            while True:
                classes = list(rng.choice(rep + act, n_classes, replace=False))
                if set(classes) & set(rep) and set(classes) & set(act):
                    break
            parts = []
            for c in classes:
                need = HDM05_SET_REPS if c in HDM05_REPETITIVE else 1
                parts.append((str(c), clips[actor, c][used[c] : used[c] + need]))
                used[c] += need
            plans[f"{prefix}_{actor}_{i}"] = (actor, parts)
    return plans


def hdm05_sequence(data_dir, actor: str, parts) -> tuple:
    """Read and join the clips of one plan of :func:`hdm05_action_plans`.

    Returns
    -------
    recording : Recording
    cuts : list of int
        First frame of every class after the first (joins inside a repetition set are not
        cuts).
    """
    from streamseg.io import read

    asf = Path(data_dir) / "hdm05_reps" / "asf" / f"HDM_{actor}.asf"
    recs, class_starts, n = [], [], 0
    for _cls, paths in parts:
        class_starts.append(n)
        for p in paths:
            r = read(p, skeleton=asf)
            recs.append(r)
            n += r.n_frames
    joined, _ = concatenate(recs)
    return joined, class_starts[1:]


def hdm05_action_sequences(data_dir, per_actor: int = 3, seed: int = 0) -> dict:
    """``name -> (recording, cuts, plan)`` for every plan of :func:`hdm05_action_plans`."""
    out = {}
    for name, (actor, parts) in hdm05_action_plans(data_dir, per_actor, seed=seed).items():
        rec, cuts = hdm05_sequence(data_dir, actor, parts)
        out[name] = (rec, cuts, parts)
    return out


#: Seeds of the fresh held-out joins: drawn once, after the nine ``hdm`` joins were in use.
FRESH_SEED = 11
FRESH2_SEED = 12


def fresh_action_plans(data_dir) -> dict:
    """Plans of the nine "fresh" HDM05 joins: the construction of :func:`hdm05_action_plans`
    (seed :data:`FRESH_SEED`) from the clips no ``hdm`` join uses; names ``fresh_<actor>_<i>``."""
    old = hdm05_action_plans(data_dir)
    return hdm05_action_plans(data_dir, per_actor=3, seed=FRESH_SEED, exclude=old, prefix="fresh")


def fresh2_action_plans(
    data_dir, per_actor: int = 3, n_classes: int = 5, min_classes: int = 3
) -> dict:
    """Plans of the "fresh2" joins, from the clips neither the ``hdm`` nor the fresh joins use.

    Per actor, up to ``per_actor`` sequences of ``min(n_classes, k)`` distinct classes drawn
    (seed :data:`FRESH2_SEED`) from the ``k`` classes with a clip left, none when
    ``k < min_classes``; a repetitive class is a set of ``min(HDM05_SET_REPS, left)``
    consecutive repetitions, a whole-action class one clip: what the remaining clips allow.

    Returns
    -------
    dict
        ``name -> (actor, [(class, [path, ...]), ...])``, names ``fresh2_<actor>_<i>``.
    """
    old = hdm05_action_plans(data_dir)
    done = {**old, **fresh_action_plans(data_dir)}
    taken = {p for _a, parts in done.values() for _c, paths in parts for p in paths}
    clips = {k: [p for p in v if p not in taken] for k, v in hdm05_clips(data_dir).items()}
    rng = np.random.default_rng(FRESH2_SEED)
    plans = {}
    for actor in HDM05_ACTORS:
        used = dict.fromkeys(HDM05_REPETITIVE + HDM05_ACTIONS, 0)
        for i in range(per_actor):
            left = {c: len(clips.get((actor, c), [])) - used[c] for c in used}
            avail = [c for c in used if left[c] > 0]
            if len(avail) < min_classes:
                break
            parts = []
            for c in rng.choice(avail, min(n_classes, len(avail)), replace=False):
                c = str(c)
                need = min(HDM05_SET_REPS, left[c]) if c in HDM05_REPETITIVE else 1
                parts.append((c, clips[actor, c][used[c] : used[c] + need]))
                used[c] += need
            plans[f"fresh2_{actor}_{i}"] = (actor, parts)
    return plans


# --- streams where actions return after the relabel history -----------------------------------

#: Streams joined from labelled CMU takes so that actions come back more than 60 s (the
#: daemon's default history) after they were last seen; fixed before any result. The joins
#: are ABRUPT. ``(take, first, end)`` parts; ``end`` None = to the take's end. 14_14 and 14_20
#: are two takes of one subject doing partly the same exercises (jumping jacks, knee raises,
#: arm circles, twists); 86_01 is split at its fourth action (frame 2500) so that its walk and
#: punch return after both exercise takes.
RETURN_CMU_STREAMS = {
    "ret_14_86_14": (("14_14", 0, None), ("86_01", 0, None), ("14_20", 0, None)),
    "ret_86_14_14_86": (
        ("86_01", 0, 2500),
        ("14_14", 0, None),
        ("14_20", 0, None),
        ("86_01", 2500, None),
    ),
}
#: HDM05 return streams, one per actor: the first half of the clips of each returning class,
#: then every clip of the other classes (at least 70 s), then the second half.
HDM05_RETURNING = ("squat1Reps", "hopBothLegs1hops")
HDM05_BETWEEN = (
    "depositFloorR",
    "grabHighR",
    "lieDownFloor",
    "throwBasketball",
    "kickLFront1Reps",
    "elbowToKnee1RepsLelbowStart",
)


def _cmu_take(data_dir, name):
    from streamseg.evaluation.labels import read_labels
    from streamseg.io import read

    root = Path(data_dir)
    if name == "86_01":
        rec = read(root / "cmu86/86_01.amc.gz", skeleton=root / "cmu86/86.asf")
        labels = read_labels(root / "cmu86/labels_86_01.csv", name)
    else:
        rec = read(root / f"cmu_exercise/{name}.amc.gz", skeleton=root / "cmu86/86.asf")
        labels = read_labels(root / "cmu_exercise/labels.csv", name)
    names = np.full(rec.n_frames, "", dtype=object)
    for seg in labels:
        names[seg.start : min(seg.end, rec.n_frames)] = seg.label
    return rec, names


def _slice(rec, a, b):
    rot = None if rec.rotations is None else rec.rotations[a:b]
    return replace(rec, positions=rec.positions[a:b], rotations=rot)


def return_streams(data_dir) -> dict:
    """Long labelled streams whose actions return after the relabel history (joins abrupt).

    Returns
    -------
    dict
        ``name -> (recording, names)``: ``names`` (n_frames,) object array, the human action
        name of every frame ("" where unlabelled); one name means one action across parts
        (e.g. ``JumpJack`` in 14_14 and 14_20; an HDM05 class).
    """
    from streamseg.io import read

    out = {}
    takes = {}
    for name, parts in RETURN_CMU_STREAMS.items():
        recs, names = [], []
        for take, a, b in parts:
            if take not in takes:
                takes[take] = _cmu_take(data_dir, take)
            rec, lab = takes[take]
            b = rec.n_frames if b is None else b
            recs.append(_slice(rec, a, b))
            names.append(lab[a:b])
        out[name] = (concatenate(recs)[0], np.concatenate(names))
    clips = hdm05_clips(data_dir)
    for actor in HDM05_ACTORS:
        asf = Path(data_dir) / "hdm05_reps" / "asf" / f"HDM_{actor}.asf"
        order = []
        for c in HDM05_RETURNING:
            p = clips[actor, c]
            order += [(c, q) for q in p[: len(p) // 2]]
        for c in HDM05_BETWEEN:
            order += [(c, q) for q in clips[actor, c]]
        for c in HDM05_RETURNING:
            p = clips[actor, c]
            order += [(c, q) for q in p[len(p) // 2 :]]
        recs = [read(q, skeleton=asf) for _, q in order]
        names = np.concatenate(
            [np.full(r.n_frames, c, dtype=object) for (c, _), r in zip(order, recs, strict=True)]
        )
        out[f"ret_hdm_{actor}"] = (concatenate(recs)[0], names)
    return out
