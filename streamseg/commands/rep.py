"""``streamseg segment|eval FILE --method rep``: sets of repetitions, counted.

FILE is a recording with joint names a skeleton map knows (CMU/HDM05 AMC + ``--skeleton``,
BVH, npz) or a matrix ``.npy``/``.csv`` of pose features (rows = frames; ``--fps``
required). The counter is the live one (:mod:`streamseg.online.repetition`) run over the
whole file; the sets are named by the action labels of ``segment --method aca``.
"""

from __future__ import annotations

import time
from pathlib import Path

from streamseg.commands.output import evaluation, segmentation, warn
from streamseg.config import RepetitionConfig
from streamseg.exceptions import ParameterError

_D = RepetitionConfig()


def add_arguments(group) -> None:
    """Repetition options (all prefixed ``--rep-``)."""
    group.add_argument(
        "--rep-min-amplitude",
        type=float,
        default=_D.min_amplitude,
        metavar="A",
        help="smallest movement counted as a repetition, in pose-distance "
        f"units, about radians (default {_D.min_amplitude:g})",
    )
    group.add_argument(
        "--rep-max-dissimilarity",
        type=float,
        default=_D.max_dissimilarity,
        metavar="R",
        help="consecutive repetitions are alike when their DTW "
        "distance is at most this share of their amplitude "
        f"(default {_D.max_dissimilarity:g})",
    )
    group.add_argument(
        "--rep-pause",
        type=float,
        default=_D.pause_s,
        metavar="S",
        help=f"a rest this long ends a set, seconds (default {_D.pause_s:g})",
    )
    group.add_argument(
        "--rep-no-labels",
        action="store_true",
        help="do not name the sets by their action label (skips the HACA run, "
        "about 1.5 s per 40 s of motion)",
    )


def _config(args) -> RepetitionConfig:
    return RepetitionConfig(
        min_amplitude=args.rep_min_amplitude,
        max_dissimilarity=args.rep_max_dissimilarity,
        pause_s=args.rep_pause,
    )


def _run(args, labels: bool = True):
    """(config, fitted RepetitionSegmenter, per-set labels or None, seconds)."""
    from streamseg.commands.inputs import is_matrix, read_recording
    from streamseg.io.matrix import read_matrix
    from streamseg.offline.repetition import RepetitionSegmenter

    cfg = _config(args)
    t0 = time.perf_counter()
    set_labels = None
    if is_matrix(args):
        if args.fps is None:
            raise ParameterError(
                "--fps is required with a feature matrix (.npy/.csv): the frame rate of its rows"
            )
        seg = RepetitionSegmenter(cfg, float(args.fps)).fit(read_matrix(args.file))
    else:
        rec = read_recording(args)
        seg = RepetitionSegmenter(cfg).fit(rec)
        if labels and seg.sets_ and not getattr(args, "rep_no_labels", False):
            from streamseg.offline.missing_frames import bridge_missing_frames
            from streamseg.offline.sets import action_labels, label_sets

            set_labels = label_sets(action_labels(bridge_missing_frames(rec)[0]), seg.sets_)
    lost = getattr(seg, "lost_joints_", [])
    if lost:
        warn(
            args,
            f"{', '.join(lost)} lost in most frames: counted with the other body parts "
            "(held where last seen; never seen: the bones ending there are left out)",
        )
    n_bad, n = int(seg.n_missing_frames_), int(seg.n_frames_)
    if n_bad and (n_bad >= n or not getattr(args, "gaps", None)):  # gaps: said at reading
        what = "frames have NaN values"
        warn(
            args,
            f"{n_bad} of {n} {what}: bridged (a joint lost up to 0.5 s interpolated, "
            "longer held where last seen)"
            if n_bad < n
            else f"all {n} {what}: nothing to count",
        )
    return cfg, seg, set_labels, time.perf_counter() - t0


def _sets(seg, set_labels) -> list:
    """The JSON "sets": per set its label, count, tempo, confidence, the joint that moves
    most (``rom_joint``) and repetitions (start, end, ``duration_s``, ``rom_deg`` of that
    joint, ``likeness`` to the one before)."""
    out = []
    for i, st in enumerate(seg.sets_):
        d = dict(st)
        d["label"] = None if set_labels is None else set_labels[i]
        per = zip(st["repetitions"], d.pop("durations_s"), d.pop("rom_deg"), d.pop("likeness"))
        d["repetitions"] = [
            {"start": a, "end": b, "duration_s": t, "rom_deg": r, "likeness": k}
            for (a, b), t, r, k in per
        ]
        out.append(d)
    return out


def _tiling(sets, n):
    """Segments tiling the take: every set (its label) and the stretches between (None)."""
    segs, at = [], 0
    for st in sets:
        if st["start"] > at:
            segs.append((at, st["start"], None))
        segs.append((st["start"], st["end"], st["label"]))
        at = st["end"]
    if at < n or not segs:
        segs.append((at, n, None))
    return segs


def segment(args) -> dict:
    """The sets of repetitions of ``args.file`` (docs/output.md)."""
    cfg, seg, set_labels, seconds = _run(args)
    sets = _sets(seg, set_labels)
    if args.plot:
        from streamseg.plotting.repetitions import plot_repetitions

        plot_repetitions(args.plot, seg, sets=sets, title_file=Path(args.file).name)
    reason = seg.reason_ or None
    if not seg.repetitive_:
        warn(args, f"{Path(args.file).name} holds no set of repetitions ({reason}): count 0")
    return segmentation(
        args,
        method="rep",
        n_frames=int(seg.n_frames_),
        fps=float(seg.fps_),
        segments=_tiling(sets, int(seg.n_frames_)),
        count=int(seg.count_),
        repetitive=bool(seg.repetitive_),
        reason=reason,
        n_sets=len(sets),
        sets=sets,
        repetitions=[{"start": a, "end": b} for a, b in seg.repetitions_],
        n_nan_frames=int(seg.n_missing_frames_),
        params={
            "min_amplitude": cfg.min_amplitude,
            "max_dissimilarity": cfg.max_dissimilarity,
            "pause_s": cfg.pause_s,
            "seconds": round(seconds, 3),
        },
    )


def true_sets(rows) -> list:
    """Label rows (one per repetition, in time order) as sets: ``(start, end, label, reps)``.

    Consecutive rows of one label are one set; a set of one row is an action take or a
    single repetition, whose true count is 0 (a set is counted from two repetitions on).
    """
    out = []
    for r in rows:
        if out and out[-1][2] == r.label:
            out[-1][3].append((r.start, r.end))
        else:
            out.append([r.start, r.end, r.label, [(r.start, r.end)]])
    return [(reps[0][0], reps[-1][1], label, reps) for _, _, label, reps in out]


def score_sets(found_sets, sets) -> list:
    """Per true set: the found repetitions whose middle frame lies in it, scored.

    Parameters
    ----------
    found_sets : list of list of (int, int)
        The repetitions of every found set.
    sets : list
        :func:`true_sets`.

    Returns
    -------
    list of dict
        ``start``, ``end``, ``label``, ``true_count``, ``count``, ``count_error``, ``right``
        (the count is right and every repetition found there is of one found set) and
        ``alpha`` (:func:`~streamseg.evaluation.metrics.matched_repetition_accuracy`; None
        for a true count of 0).
    """
    from streamseg.evaluation.metrics import count_error, matched_repetition_accuracy

    mids = [((a + b) // 2, i, (a, b)) for i, reps in enumerate(found_sets) for a, b in reps]
    out = []
    for start, end, label, reps in sets:
        mine = [(i, r) for m, i, r in mids if start <= m < end]
        n_true = len(reps) if len(reps) >= 2 else 0
        n = len(mine)
        out.append(
            {
                "start": int(start),
                "end": int(end),
                "label": label,
                "true_count": n_true,
                "count": n,
                "count_error": count_error(n, n_true),
                "right": n == n_true and len({i for i, _ in mine}) <= 1,
                "alpha": (
                    matched_repetition_accuracy([r for _, r in mine], reps) if n_true else None
                ),
            }
        )
    return out


def set_scores(found_sets, rows, count: int) -> dict:
    """The scores of ``eval --method rep`` (and ``batch --labels``) of a take's found sets.

    Parameters
    ----------
    found_sets : list of list of (int, int)
        The repetitions of every found set, frames.
    rows : list
        The take's label rows (:func:`streamseg.evaluation.labels.read_labels`), one per
        repetition; consecutive rows of one label are a set (:func:`true_sets`).
    count : int
        Repetitions found in the take.

    Returns
    -------
    dict
        ``alpha`` (the mean over the sets of two or more repetitions, None without one),
        ``count``, ``true_count``, ``count_error``, ``exact_sets``, ``actions_counted_zero``
        and ``sets`` (:func:`score_sets`).
    """
    scored = score_sets(found_sets, true_sets(rows))
    rep = [s for s in scored if s["true_count"]]
    act = [s for s in scored if not s["true_count"]]
    true_count = int(sum(s["true_count"] for s in rep))
    return {
        "alpha": float(sum(s["alpha"] for s in rep) / len(rep)) if rep else None,
        "count": int(count),
        "true_count": true_count,
        "count_error": int(count) - true_count,
        "exact_sets": f"{sum(s['right'] for s in rep)} of {len(rep)}",
        "actions_counted_zero": f"{sum(s['count'] == 0 for s in act)} of {len(act)}",
        "sets": scored,
    }


def evaluate(args) -> dict:
    """Counts and alpha against ``args.labels`` (one row per repetition; consecutive rows of
    one label are a set; a lone row is an action or a single repetition, true count 0)."""
    from streamseg.evaluation.labels import read_labels

    cfg, seg, _, seconds = _run(args, labels=False)
    sequence = args.sequence or Path(args.file).name.split(".")[0]
    rows = read_labels(args.labels, sequence)
    scores = set_scores([st["repetitions"] for st in seg.sets_], rows, int(seg.count_))
    if args.plot:
        from streamseg.plotting.repetitions import plot_repetitions

        plot_repetitions(
            args.plot,
            seg,
            sets=_sets(seg, None),
            truth=[(r.start, r.end) for r in rows],
            title_file=Path(args.file).name,
        )
    return evaluation(
        args,
        method="rep",
        n_frames=int(seg.n_frames_),
        fps=float(seg.fps_),
        **scores,
        repetitive=bool(seg.repetitive_),
        reason=seg.reason_ or None,
        n_nan_frames=int(seg.n_missing_frames_),
        seconds=round(seconds, 3),
        note="per labelled set: the found repetitions whose middle frame lies in it, right "
        "when their number is the true count and they are of one found set; alpha "
        "(eq. 15, repetitions matched by overlap) is the mean over the sets of two or "
        "more repetitions",
    )
