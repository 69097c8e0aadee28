"""``streamseg segment|eval FILE --method lof``: cuts from LOF over sliding-window histograms.

FILE is a recording (features: ``streamseg.skeleton.bone_angles``, the paper's 8 bone angles
and, unless ``--inclinations off`` or ``--preset paper``, the 9 bone inclinations from the up
axis, then the 2 root-speed columns unless ``--root-speed 0``) or such a feature matrix
``.npy``/``.csv`` with 17 (or 8) columns, the root speeds then off, or with them, 19 (or 10)
(``--fps`` is required). Offline
by default; ``--online`` streams the frames through the live detector in 120-frame packets and
reports each cut's latency.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from streamseg.commands.output import evaluation, segmentation, warn
from streamseg.config import LOFConfig
from streamseg.exceptions import ParameterError
from streamseg.recording import UP_AXES

_D = LOFConfig()
# option -> LOFConfig field
_FIELDS = {
    "window": "window_s",
    "step": "step_s",
    "bins": "bins",
    "k": "k",
    "buffer": "buffer_s",
    "delay": "delay_s",
    "threshold": "threshold_mads",
    "min_score": "min_score",
    "exclusion": "exclusion",
    "refine": "refine_s",
    "inclinations": "inclinations",
    "min_contrast": "min_contrast",
    "contrast": "contrast_s",
    "novelty": "novelty",
    "early_delay": "early_delay_s",
    "onset": "onset_mads",
    "root_speed": "root_speed_max",
}


def add_arguments(group) -> None:
    """LOF options (times in seconds); unset options keep the preset's value."""
    group.add_argument(
        "--online",
        action="store_true",
        help="stream the frames through the live detector (reports latency)",
    )
    group.add_argument(
        "--preset",
        choices=("default", "paper"),
        default="default",
        help="default: chosen on 86_01 + one HDM05 join; paper: Xing et al. 2015 "
        "(500/45 frames at 120 Hz, k=20, every peak of the simplified "
        "LOF curve; 9.75 s delay)",
    )
    group.add_argument(
        "--window",
        type=float,
        metavar="S",
        help=f"LOF window length, seconds (default {_D.window_s:g})",
    )
    group.add_argument(
        "--step", type=float, metavar="S", help=f"LOF window step, seconds (default {_D.step_s:g})"
    )
    group.add_argument(
        "--bins", type=int, metavar="L", help=f"histogram bins per bone angle (default {_D.bins})"
    )
    group.add_argument("--k", type=int, metavar="K", help=f"LOF neighbours (default {_D.k})")
    group.add_argument(
        "--buffer",
        type=float,
        metavar="S",
        help=f"streaming LOF buffer, seconds (default {_D.buffer_s:g})",
    )
    group.add_argument(
        "--delay",
        type=float,
        metavar="S",
        help=f"peak confirmation delay, seconds (default {_D.delay_s:g})",
    )
    group.add_argument(
        "--early-delay",
        type=float,
        metavar="S",
        help="two stages: also decide each window S seconds after it and emit "
        "its cut at once as pending, confirmed or withdrawn at --delay "
        "(the final cuts stay --delay's; with --online the JSON gives "
        "each cut's first-emission latency; default off; "
        "benchmarks/lof_latency.py shows the trade-off; replaces --onset's rule)",
    )
    group.add_argument(
        "--onset",
        type=float,
        metavar="MADS",
        help="the onset rule: a pending cut as soon as the newest window's LOF has risen "
        f"{_D.onset_rises} windows in a row past the median + MADS MADs, confirmed or "
        "withdrawn at --delay (e.g. 4; default off: one stage)",
    )
    group.add_argument(
        "--threshold",
        type=float,
        metavar="MADS",
        help=f"peak threshold in MADs above the median (default {_D.threshold_mads:g})",
    )
    group.add_argument(
        "--min-score",
        type=float,
        metavar="LOF",
        help=f"lowest LOF a cut may have (default {_D.min_score:g})",
    )
    group.add_argument(
        "--exclusion",
        type=float,
        metavar="W",
        help=f"temporal exclusion zone in windows (default {_D.exclusion:g})",
    )
    group.add_argument(
        "--refine",
        type=float,
        metavar="S",
        help="move each cut to the largest before/after histogram contrast "
        f"within S seconds of the peak window's centre (default "
        f"{_D.refine_s:g}; 0: the centre, as in the paper)",
    )
    group.add_argument(
        "--min-contrast",
        type=float,
        metavar="D",
        help="confirm a cut only when the histograms before and after it differ "
        f"by this cosine distance (default {_D.min_contrast:g}; 0: no "
        "confirmation, as in the paper)",
    )
    group.add_argument(
        "--contrast",
        type=float,
        metavar="S",
        help=f"seconds on each side of the confirming contrast (default {_D.contrast_s:g})",
    )
    group.add_argument(
        "--novelty",
        type=float,
        metavar="D",
        help="confirm a cut only when the whole current segment and the "
        "contrast seconds after the cut differ by this cosine distance "
        f"(default {_D.novelty:g}; 0: no novelty check, as in the paper)",
    )
    group.add_argument(
        "--inclinations",
        choices=("on", "off"),
        type=str.lower,
        help="add each bone's inclination from the up axis to the 8 bone "
        "angles (default on; the paper preset: off)",
    )
    group.add_argument(
        "--root-speed",
        type=float,
        metavar="V",
        help="the root's horizontal and vertical speed (body scales per "
        "second mapped to the last bin) in the LOF windows, not in the "
        f"checks that place a cut (default {_D.root_speed_max:g}; 0: off, "
        "as in the paper; a feature matrix without them: off)",
    )
    group.add_argument(
        "--up",
        choices=UP_AXES,
        help="world up axis of the recording's positions (default: the format's, y for AMC/BVH)",
    )


def config_from_args(args) -> LOFConfig:
    """The preset with every given option applied."""
    over = {f: getattr(args, o) for o, f in _FIELDS.items() if getattr(args, o, None) is not None}
    if "inclinations" in over:
        over["inclinations"] = over["inclinations"] == "on"
    if over.get("onset_mads") == 0:
        over["onset_mads"] = None
    if getattr(args, "preset", "default") == "paper":
        return LOFConfig.paper(**over)
    return LOFConfig(**over)


def _angles(args, config: LOFConfig):
    """(features (n, d), fps, config) of ``args.file``: ``config``'s features, or, for a
    matrix of the bone features alone, those with the root speeds turned off."""
    from streamseg.commands.inputs import is_matrix, read_recording
    from streamseg.io.matrix import read_matrix

    if is_matrix(args):
        if args.fps is None:
            raise ParameterError("a bone-angle matrix has no frame rate: give --fps (e.g. 120)")
        if getattr(args, "up", None):
            raise ParameterError(
                "--up applies to recordings: a feature matrix's inclinations are already computed"
            )
        m = read_matrix(args.file)
        width = m.shape[1] if m.ndim == 2 else None
        bone = config.n_features - config.root_columns
        if width in (8, 17) and width != bone:  # the other feature set
            raise ParameterError(
                f"{args.file} has {width} columns, the features of "
                f"--inclinations {'off' if width == 8 else 'on'}; these "
                f"options take {bone}"
            )
        if width == bone and config.root_columns:  # no positions: no root speeds
            config = dataclasses.replace(config, root_speed_max=0.0)
        if width not in (bone, config.n_features):
            hint = (
                f"; if they are joint positions ({width // 3} joints x 3), give --joints "
                "kinect|blazepose|coco17|body25 or a header row naming each column "
                "<joint>_x,<joint>_y,<joint>_z"
                if width and width % 3 == 0
                else ""
            )
            raise ParameterError(
                f"{args.file} has {width} columns, not the cut detector's "
                f"features ({bone}, or {config.n_features} with the root "
                f"speeds; --inclinations off: 8 or 10){hint}"
            )
        from streamseg.offline.lof import lof_features  # here: segment --method aca needs none

        return lof_features(m, config), float(args.fps), config  # validates any other width
    if getattr(args, "up", None) and not config.inclinations:
        raise ParameterError(
            "--up has no effect without the inclinations (--inclinations off or --preset paper)"
        )
    from streamseg.offline.lof import position_features

    rec = read_recording(args)
    up = getattr(args, "up", None) or rec.skeleton.up
    if config.inclinations:
        _warn_up(args, rec, up)
    return (
        position_features(rec.positions, rec.skeleton, rec.fps, config, up),
        float(rec.fps),
        config,
    )


def _warn_up(args, rec, up: str) -> None:
    """Warn when the body stands along another axis than ``up``."""
    from streamseg.skeleton.bones import bone_point_indices, likely_up, spine_directions

    axis = likely_up(spine_directions(rec.positions, bone_point_indices(rec.skeleton))[0], up)
    if axis is not None:
        warn(
            args,
            f"in {rec.source or 'the recording'} the spine points along {axis}, not "
            f"along the up axis {up}: give --up {axis}, or the bone inclinations change with "
            "the heading",
        )


def _run(args, angles, fps, config: LOFConfig, online: bool) -> dict:
    window = config.frames(fps)["window"]
    if angles.shape[0] < window:
        n = angles.shape[0]
        warn(
            args,
            f"the recording has {n} frame{'s' if n != 1 else ''} ({n / fps:.2f} s), "
            f"shorter than the cut detector's window of {window} frames "
            f"({window / fps:.2f} s): no cut can be found (a shorter --window would look at it)",
        )
    from streamseg.offline.lof_report import lof_report

    return lof_report(angles, fps, config, online)


def _plot(args, res, n, fps, title, truth=None):
    from streamseg.plotting.curve import plot_curve

    extra = []
    if "final" in res:
        extra = [(res["final"][0], res["final"][1], "LOF at end of stream")]
    plot_curve(
        args.plot,
        res["centres"],
        res["lof"],
        res["cuts"],
        fps=fps,
        n_frames=n,
        truth=truth,
        threshold=res["threshold"],
        title=title,
        ylabel="LOF when decided" if extra else "LOF",
        extra=extra,
    )


def segment(args) -> dict:
    """Cut ``args.file``; the JSON of the issue (n_frames, fps, method, cuts, segments, ...)."""
    angles, fps, config = _angles(args, config_from_args(args))
    res = _run(args, angles, fps, config, bool(args.online))
    n = int(angles.shape[0])
    if args.plot:
        _plot(
            args,
            res,
            n,
            fps,
            f"{Path(args.file).name}: LOF "
            f"({'online' if args.online else 'offline'}, {args.preset})",
        )
    bounds = [0, *res["cuts"], n]
    extra = {"mode": "online" if args.online else "offline"}
    if args.online:
        extra["cut_latency_frames"] = res["latency"]
        extra["cut_latency_s"] = [round(v / fps, 4) for v in res["latency"]]
        if config.two_stage:
            extra["cut_first_latency_frames"] = res["first_latency"]
            extra["cut_first_latency_s"] = [round(v / fps, 4) for v in res["first_latency"]]
            extra["withdrawn_cuts"] = res["withdrawn"]
    extra["params"] = {
        **dataclasses.asdict(config),
        "preset": args.preset,
        "online": bool(args.online),
        "frames": res["geometry"],
    }
    return segmentation(
        args,
        method="lof",
        n_frames=n,
        fps=fps,
        segments=[(s, e, None) for s, e in zip(bounds[:-1], bounds[1:]) if e > s],
        **extra,
    )


def evaluate(args) -> dict:
    """Precision/recall/F1 (label window + 0.5 s, and flat 1 s), covering, latency."""
    from streamseg.commands.output import check_label_extent
    from streamseg.evaluation.labels import cut_windows, read_labels, true_cuts
    from streamseg.evaluation.metrics import covering, cut_scores, latency_stats

    angles, fps, config = _angles(args, config_from_args(args))
    res = _run(args, angles, fps, config, bool(args.online))
    n = int(angles.shape[0])
    sequence = args.sequence or Path(args.file).name.split(".")[0]
    segs = read_labels(args.labels, sequence)
    check_label_extent(args, segs, sequence, n)
    truth, windows = true_cuts(segs, n), cut_windows(segs)[: len(true_cuts(segs, n))]
    win = cut_scores(res["cuts"], truth, windows=windows, margin=int(round(0.5 * fps)))
    flat = cut_scores(res["cuts"], truth, tolerance=int(round(1.0 * fps)))
    out = {
        "mode": "online" if args.online else "offline",
        "preset": args.preset,
        "n_true": win["n_true"],
        "n_cuts": win["n_pred"],
        "precision": win["precision"],
        "recall": win["recall"],
        "f1": win["f1"],
        "precision_1s": flat["precision"],
        "recall_1s": flat["recall"],
        "f1_1s": flat["f1"],
        "covering": covering(res["cuts"], truth, n),
        "cuts": res["cuts"],
        "true_cuts": truth,
    }
    if args.online:
        lat = latency_stats(res["latency"])
        out.update(
            latency_median_frames=lat["median"],
            latency_max_frames=lat["max"],
            latency_median_s=lat["median"] / fps,
        )
        if config.two_stage:
            first = latency_stats(res["first_latency"])
            out.update(
                first_latency_median_frames=first["median"],
                first_latency_max_frames=first["max"],
                first_latency_median_s=first["median"] / fps,
                n_withdrawn=len(res["withdrawn"]),
            )
    if args.plot:
        _plot(
            args,
            res,
            n,
            fps,
            f"{sequence}: LOF F1 {win['f1']:.2f} "
            f"({'online' if args.online else 'offline'}, {args.preset})",
            truth=[(s.start, min(s.end, n), s.label) for s in segs],
        )
    return evaluation(args, method="lof", n_frames=n, fps=fps, **out)
