"""``streamseg segment|eval FILE --method rep``: cut a repetitive exercise into repetitions.

FILE is a recording with Acclaim joint names (CMU/HDM05 AMC + ``--skeleton``; the four-pass
kinematic UKF turns it into joint angles) or a matrix ``.npy``/``.csv`` of kinematic parameter
trajectories (rows = frames, radians; ``--fps`` required). Method: Wang et al. 2015.
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
    group.add_argument("--rep-power-ratio", type=float, default=_D.power_ratio, metavar="R",
                       help=f"share of power at the primary frequency the selected parameters "
                            f"hold (default {_D.power_ratio})")
    group.add_argument("--rep-band-width", type=float, default=_D.bandpass_width_cycles,
                       metavar="C", help="band-pass width around the primary frequency, cycles "
                                         f"per sequence (default {_D.bandpass_width_cycles:g})")
    group.add_argument("--rep-min-cycles", type=float, default=_D.min_cycles, metavar="C",
                       help=f"fewest cycles in the sequence (default {_D.min_cycles:g})")
    group.add_argument("--rep-max-hz", type=float, default=_D.max_frequency_hz, metavar="HZ",
                       help=f"fastest repetition rate (default {_D.max_frequency_hz:g})")
    group.add_argument("--rep-noise", type=float, default=_D.position_noise, metavar="S",
                       help="UKF position noise in body-scale units, 1 = one long bone "
                            f"(default {_D.position_noise:g})")
    group.add_argument("--rep-passes", type=int, choices=(2, 4), default=_D.ukf_passes,
                       help=f"UKF passes (default {_D.ukf_passes})")
    group.add_argument("--rep-seed", type=int, default=_D.seed, metavar="N",
                       help="k-means seed (default 0)")
    group.add_argument("--rep-sets", action="store_true",
                       help="eval: the take is a routine; cut it into sets as segment does and "
                            "score each labelled set (without it, eval counts the whole take "
                            "as one exercise, so its count can differ from segment's; label "
                            "rows: one per repetition, "
                            "consecutive rows of one label are a set; a lone row is an action "
                            "or a single repetition, true count 0)")


def _config(args) -> RepetitionConfig:
    return RepetitionConfig(power_ratio=args.rep_power_ratio,
                            bandpass_width_cycles=args.rep_band_width,
                            min_cycles=args.rep_min_cycles, max_frequency_hz=args.rep_max_hz,
                            position_noise=args.rep_noise, ukf_passes=args.rep_passes,
                            seed=args.rep_seed)


def _run(args, sets=False):
    """(config, fitted segmenter, seconds); with ``sets`` a :class:`RoutineSegmenter` for a
    recording (a parameter matrix has no joint positions to cut into actions: one set)."""
    from streamseg.commands.inputs import is_matrix, read_recording
    from streamseg.io.matrix import read_matrix
    from streamseg.offline.repetition import RepetitionSegmenter

    cfg = _config(args)
    t0 = time.perf_counter()
    if is_matrix(args):
        if args.fps is None:
            raise ParameterError("--fps is required with a parameter matrix (.npy/.csv): "
                                 "the frame rate of its rows")
        seg = RepetitionSegmenter(cfg, float(args.fps)).fit(read_matrix(args.file))
    else:
        rec = read_recording(args)
        if sets:
            from streamseg.offline.sets import RoutineSegmenter

            seg = RoutineSegmenter(cfg).fit(rec)
        else:
            seg = RepetitionSegmenter(cfg).fit(rec)
    n_bad = int(getattr(seg, "n_missing_frames_", 0))
    n = int(getattr(seg, "whole_", seg).n_frames_) if n_bad else 0
    if n_bad and (n_bad >= n or not getattr(args, "gaps", None)):  # gaps: said at reading
        # (a matrix with a NaN is refused by read_matrix; a recording's frames are skipped)
        what = "frames have NaN joint positions"
        warn(args, f"{n_bad} of {n} {what}: skipped (bridged by interpolation from the "
             "frames around them)" if n_bad < n else f"all {n} {what}: nothing to count")
    return cfg, seg, time.perf_counter() - t0


def _sets(seg) -> list:
    """The JSON "sets" of a fitted RoutineSegmenter or RepetitionSegmenter."""
    from streamseg.offline.sets import RepetitionSet

    if hasattr(seg, "sets_"):
        sets = seg.sets_
    else:
        sets = [RepetitionSet(0, int(seg.n_frames_), 0, int(seg.count_), bool(seg.repetitive_),
                              seg.reason_, list(seg.repetitions_))]
    return [{"start": st.start, "end": st.end, "label": st.label, "count": st.count,
             "repetitive": st.repetitive, "reason": st.reason or None,
             "repetitions": [{"start": int(a), "end": int(b)} for a, b in st.repetitions]}
            for st in sets]


def segment(args) -> dict:
    """Repetitions of ``args.file`` as the JSON-able result the issues specify.

    A recording is first cut into action sets (:class:`streamseg.offline.sets.
    RoutineSegmenter`) and counted inside each; ``count`` and ``repetitions`` are those of
    every set together; ``repetitive`` says whether any set is repetitive.
    """
    cfg, seg, seconds = _run(args, sets=True)
    whole = getattr(seg, "whole_", seg)
    sets = _sets(seg)
    repetitive = any(st["repetitive"] for st in sets)
    if args.plot:
        from streamseg.plotting.repetitions import plot_repetitions

        plot_repetitions(args.plot, whole, sets=sets)
    reason = None
    if not repetitive:
        reason = (sets[0]["reason"] if len(sets) == 1 else
                  "no set is repetitive" if sets else whole.reason_)
        warn(args, f"{Path(args.file).name} does not look repetitive ({reason}): count 0")
    a = whole.analysis_
    params = {
        "selected": [] if a is None else [whole.param_names_[i] for i in a.selected],
        "k_star": 0 if a is None else int(a.k_star),
        "n_candidates": 0 if a is None else int(a.candidates.size),
        "concentration": 0.0 if a is None else round(float(a.concentration), 4),
        "power_ratio": cfg.power_ratio,
        "bandpass_width_cycles": cfg.bandpass_width_cycles,
        "ukf_passes": cfg.ukf_passes,
        "seconds": round(seconds, 3),
    }
    fps = float(whole.fps_)
    return segmentation(
        args, method="rep", n_frames=int(whole.n_frames_), fps=fps,
        # the action sets are the segments: a routine's exercises, each counted
        segments=[(st["start"], st["end"], st["label"]) for st in sets],
        count=int(seg.count_),
        repetitive=repetitive,
        reason=reason,
        repetitions=[{"start": int(s), "end": int(e)} for s, e in seg.repetitions_],
        sets=sets,
        n_nan_frames=int(getattr(seg, "n_missing_frames_", 0)),
        n_actions=int(getattr(seg, "n_clusters_", 1)),
        primary_frequency_hz=float(whole.primary_frequency_hz_),
        params=params,
    )


def evaluate(args) -> dict:
    """Accuracy alpha (eq. 15) and count error against ``args.labels``.

    The whole take is counted as one exercise (one set): unlike ``segment --method rep``, which
    cuts a take into action sets first, so on a routine the two counts differ (CMU 86_01: 0
    here, the whole take failing the repetitive test, against its sets' 10 in ``segment``).
    ``--rep-sets`` (:func:`_evaluate_sets`) scores a routine per set, as ``segment`` counts it.

    The label rows of the sequence must be one row per repetition (start, end of each
    repetition). Labels of whole exercise blocks (one row per exercise, like the CMU exercise
    routines' labels.csv) do not mark repetitions: alpha is then meaningless; use
    ``segment`` on each block instead.
    """
    from streamseg.evaluation.labels import read_labels
    from streamseg.evaluation.metrics import count_error, repetition_accuracy

    if getattr(args, "rep_sets", False):
        return _evaluate_sets(args)
    cfg, seg, seconds = _run(args)
    sequence = args.sequence or Path(args.file).name.split(".")[0]
    truth = [(s.start, s.end) for s in read_labels(args.labels, sequence)]
    if args.plot:
        from streamseg.plotting.repetitions import plot_repetitions

        plot_repetitions(args.plot, seg, truth=truth)
    if not seg.repetitive_:
        # segment --method rep cuts a take into sets first: its count can differ (86_01: 0 here,
        # 10 there); say so where the user sees the 0
        warn(args, f"{Path(args.file).name} as one exercise does not look repetitive "
             f"({seg.reason_}): count 0; `segment --method rep` cuts a take into action sets "
             "first and counts inside each, as `eval --method rep --rep-sets` scores it")
    return evaluation(
        args, method="rep", n_frames=int(seg.n_frames_), fps=float(seg.fps_),
        alpha=repetition_accuracy(seg.repetitions_, truth),
        count=int(seg.count_),
        true_count=len(truth),
        count_error=count_error(seg.count_, len(truth)),
        repetitive=bool(seg.repetitive_),
        reason=seg.reason_ or None,
        n_nan_frames=int(getattr(seg, "n_missing_frames_", 0)),
        primary_frequency_hz=float(seg.primary_frequency_hz_),
        seconds=round(seconds, 3),
        note="the whole take is one exercise, not cut into action sets as `segment --method "
             "rep` does (for a routine use --rep-sets); labels are read as one row per "
             "repetition (eq. 15 compares the i-th found and true repetition lengths)",
    )


def true_sets(rows) -> list:
    """Label rows (one per repetition, in time order) as sets: ``(start, end, label, reps)``.

    Consecutive rows of one label are one set; a set of one row is an action take or a
    single repetition, whose true count is 0 (one movement is not counted; see
    :func:`streamseg.offline.rep_analysis.not_repetitive_reason`).
    """
    out = []
    for r in rows:
        if out and out[-1][2] == r.label:
            out[-1][3].append((r.start, r.end))
        else:
            out.append([r.start, r.end, r.label, [(r.start, r.end)]])
    return [(reps[0][0], reps[-1][1], label, reps) for _, _, label, reps in out]


def score_sets(found, sets) -> list:
    """Per true set: the found repetitions whose middle frame lies in it, scored.

    Parameters
    ----------
    found : sequence of (int, int)
        Every found repetition of the take (0-based, end exclusive).
    sets : list
        :func:`true_sets`.

    Returns
    -------
    list of dict
        ``start``, ``end``, ``label``, ``true_count``, ``count``, ``count_error`` and
        ``alpha`` (eq. 15 against the set's true repetitions; None for a true count of 0).
    """
    from streamseg.evaluation.metrics import count_error, repetition_accuracy

    out = []
    for start, end, label, reps in sets:
        mine = [(a, b) for a, b in found if start <= (a + b) // 2 < end]
        n_true = len(reps) if len(reps) >= 2 else 0
        out.append({"start": int(start), "end": int(end), "label": label,
                    "true_count": n_true, "count": len(mine),
                    "count_error": count_error(len(mine), n_true),
                    "alpha": repetition_accuracy(mine, reps) if n_true else None})
    return out


def _evaluate_sets(args) -> dict:
    """``eval --method rep --rep-sets``: a routine scored per labelled set."""
    import numpy as np

    from streamseg.evaluation.labels import read_labels

    cfg, seg, seconds = _run(args, sets=True)
    whole = getattr(seg, "whole_", seg)
    sequence = args.sequence or Path(args.file).name.split(".")[0]
    scored = score_sets(seg.repetitions_, true_sets(read_labels(args.labels, sequence)))
    rep = [s for s in scored if s["true_count"]]
    act = [s for s in scored if not s["true_count"]]
    return evaluation(
        args, method="rep", n_frames=int(whole.n_frames_), fps=float(whole.fps_),
        alpha=float(np.mean([s["alpha"] for s in rep])) if rep else None,
        count=int(seg.count_),
        true_count=int(sum(s["true_count"] for s in rep)),
        count_error=int(seg.count_) - int(sum(s["true_count"] for s in rep)),
        exact_sets=f"{sum(s['count_error'] == 0 for s in rep)} of {len(rep)}",
        actions_counted_zero=f"{sum(s['count'] == 0 for s in act)} of {len(act)}",
        sets=scored,
        seconds=round(seconds, 3),
        note="per labelled set: the found repetitions whose middle frame lies in it; alpha "
             "is the mean over the sets of two or more repetitions",
    )
