"""``streamseg segment|eval FILE --method aca``: Aligned Cluster Analysis of a whole recording.

FILE is a recording (features: ``streamseg.skeleton.quaternion_features``, the paper's
14-joint quaternions) or a plain feature matrix ``.npy``/``.csv`` (rows = frames; ``--fps``
is required, as lengths are in seconds). Temporal reduction is on by default for
recordings (``--reduce 20``) and for matrices of more than 1,000 rows. Without ``--clusters``
the number of actions is found (:mod:`streamseg.offline.model_selection`).
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

from streamseg.commands.output import evaluation, segmentation, warn
from streamseg.config import ACAConfig
from streamseg.exceptions import ParameterError

_DEFAULTS = ACAConfig()


def add_arguments(group) -> None:
    """ACA options (lengths in seconds)."""
    group.add_argument(
        "--clusters",
        type=_clusters,
        default=None,
        metavar="K",
        help="number of actions (default: found, the K in 2.."
        f"{_DEFAULTS.k_max} whose segments have the best silhouette); "
        "with eval, 'labels' takes K from the human labels",
    )
    group.add_argument(
        "--hierarchical", action="store_true", help="two-level HACA (the default; kept for scripts)"
    )
    group.add_argument("--flat", action="store_true", help="one-level ACA instead of HACA")
    group.add_argument(
        "--min-len",
        type=float,
        default=None,
        metavar="S",
        help=f"shortest segment, seconds (default {_DEFAULTS.min_len_s:g})",
    )
    group.add_argument(
        "--max-len",
        type=float,
        default=None,
        metavar="S",
        help=f"longest segment, seconds (default {_DEFAULTS.max_len_s:g})",
    )
    group.add_argument(
        "--kernel",
        choices=("gaussian", "equality"),
        default="gaussian",
        help="frame kernel (equality: 1 iff frames are equal)",
    )
    group.add_argument(
        "--sigma",
        type=float,
        default=None,
        metavar="S",
        help="Gaussian bandwidth (default: from the data)",
    )
    group.add_argument(
        "--restarts",
        type=_restarts,
        default=_DEFAULTS.n_init,
        metavar="N",
        help=f"random restarts (default {_DEFAULTS.n_init})",
    )
    group.add_argument("--seed", type=int, default=0, metavar="N", help="random seed")
    group.add_argument(
        "--reduce",
        type=int,
        default=None,
        metavar="K",
        help="temporal reduction into K frame classes, 0 = off (default: "
        f"{_DEFAULTS.k_reduce} for recordings and matrices of more than "
        "1,000 rows)",
    )


def _restarts(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = 0
    if not 1 <= n <= 1000:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected a number of restarts in 1..1000 (each one is a whole ACA run)"
        )
    return n


def _clusters(text: str):
    if text == "labels":
        return text
    try:
        k = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected a number of actions or 'labels'"
        ) from None
    if k < 1:
        raise argparse.ArgumentTypeError(f"{k}: expected a number of actions >= 1")
    return k


def _load(args):
    """(features (n, d), fps, is_matrix) for ``args.file``."""
    from streamseg.commands.inputs import is_matrix, read_recording
    from streamseg.io.matrix import read_matrix

    if is_matrix(args):
        if args.fps is None:  # as lof and rep: a guessed rate would silently rescale lengths
            raise ParameterError(
                f"{Path(args.file).name} is a feature matrix with no frame "
                "rate: give --fps (rows per second; --min-len/--max-len are "
                "in seconds)"
            )
        fps = float(args.fps)
        return read_matrix(args.file), fps, True
    from streamseg.skeleton import body_features, quaternion_features

    rec = read_recording(args)
    if rec.rotations is None:  # positions only (a Kinect-like or converted take): as `rep` does
        warn(
            args,
            f"{Path(args.file).name} holds joint positions only (no rotations): ACA "
            "runs on the body's limb directions (streamseg.skeleton.body_features) "
            "instead of joint quaternions",
        )
        return body_features(rec.positions, rec.skeleton), float(rec.fps), False
    return quaternion_features(rec), float(rec.fps), False


#: a feature matrix longer than this gets temporal reduction unless ``--reduce 0``
REDUCE_ROWS = 1000
#: the longest ACA segment in frames the command accepts (the default 2 s is 240 at 120 Hz)
MAX_SEGMENT_FRAMES = 50_000


def _config(args, is_matrix, n_rows) -> ACAConfig:
    reduce = args.reduce
    if reduce is None:  # long matrices too: without it 4,579 rows took 10 minutes
        reduce = None if is_matrix and n_rows <= REDUCE_ROWS else _DEFAULTS.k_reduce
    elif reduce == 0:
        reduce = None
    values = dict(
        n_clusters=args.clusters,
        kernel=args.kernel,
        sigma=args.sigma,
        n_init=args.restarts,
        random_state=args.seed,
        k_reduce=reduce,
        hierarchical=not args.flat,
    )
    if args.min_len is not None:
        values["min_len_s"] = args.min_len
    if args.max_len is not None:
        values["max_len_s"] = args.max_len
    if "min_len_s" in values and "max_len_s" not in values:
        values["max_len_s"] = max(values["min_len_s"], _DEFAULTS.max_len_s)
    if "max_len_s" in values and "min_len_s" not in values:
        values["min_len_s"] = min(values["max_len_s"], _DEFAULTS.min_len_s)
    return ACAConfig(**values)


def _run(args, n_labels: int | None = None):
    from streamseg.offline.model_selection import fit_aca

    if args.fps is not None and args.fps <= 0:
        raise ParameterError(f"--fps={args.fps!r} is invalid: expected a frame rate > 0")
    if args.clusters == "labels" and n_labels is None:
        raise ParameterError(
            "--clusters labels takes K from human labels: use it with eval "
            "(segment has no labels), or give a number"
        )
    X, fps, is_matrix = _load(args)
    if args.clusters == "labels":
        args.clusters = n_labels
    config = _config(args, is_matrix, X.shape[0])
    longest = config.max_len_s * fps
    if longest > MAX_SEGMENT_FRAMES:  # the DP holds (longest segment x frames) numbers
        raise ParameterError(
            f"--max-len {config.max_len_s:g} s is {longest:,.0f} frames at {fps:g} Hz, more "
            f"than the {MAX_SEGMENT_FRAMES:,} an ACA segment may span: give a --max-len of at "
            f"most {MAX_SEGMENT_FRAMES / fps:g} s (the longest cycle of one action)"
        )
    t0 = time.perf_counter()
    model = fit_aca(X, config, fps, n_jobs=-1)  # restarts on every core; same result
    seconds = time.perf_counter() - t0
    if (
        config.n_clusters is not None
        and model.n_clusters_ != config.n_clusters
        and not model.reason
    ):
        most = int(X.shape[0] // max(1, round(config.min_len_s * fps)))
        warn(
            args,
            f"--clusters {config.n_clusters} asks for more actions than "
            f"{X.shape[0]} frames hold in segments of --min-len {config.min_len_s:g} s "
            f"(at most {most}): clustered with K={model.n_clusters_} (give a smaller "
            "--clusters or --min-len)",
        )
    used = len({int(lab) for _, _, lab in model.segments_})
    if config.n_clusters is not None and used < model.n_clusters_ and not model.reason:
        warn(
            args,
            f"only {used} of the {model.n_clusters_} clusters hold a segment: the "
            f"frames separate into fewer actions than --clusters {config.n_clusters} "
            "(omit --clusters to have K found)",
        )
    return X, fps, config, model, seconds


def _name(config) -> str:
    return "HACA" if config.hierarchical else "ACA"


def _k_text(k: int, config) -> str:
    how = "found" if config.n_clusters is None else "given"
    return f"{k} action{'s' if k != 1 else ''} ({how})"


def segment(args) -> dict:
    """Segment ``args.file``; returns the JSON-able result (same shape as the LOF method)."""
    X, fps, config, model, seconds = _run(args)
    if args.plot:
        from streamseg.plotting.segments import plot_segments

        plot_segments(
            args.plot,
            X,
            model.segments_,
            fps=fps,
            method=_name(config),
            title=f"{Path(args.file).name}: {_name(config)}, {_k_text(model.n_clusters_, config)}",
        )
    if model.reason:
        warn(args, f"{Path(args.file).name} was not clustered ({model.reason}): one segment")
    return segmentation(
        args,
        method="haca" if config.hierarchical else "aca",
        n_frames=int(X.shape[0]),
        fps=fps,
        segments=[(s, e, int(lab)) for s, e, lab in model.segments_],
        objective=float(model.objective_),
        n_clusters=model.n_clusters_,
        k_found=config.n_clusters is None,
        k_scores={str(k): v for k, v in model.scores_.items()},
        note=model.reason or None,  # why the recording was not clustered (one segment)
        seconds=round(seconds, 3),
        params=dataclasses.asdict(config),
    )


def evaluate(args) -> dict:
    """Hungarian-matched frame accuracy and confusion matrix (eq. 11) against ``args.labels``."""
    from streamseg.commands.output import check_label_extent
    from streamseg.evaluation.labels import frame_labels, read_labels
    from streamseg.evaluation.metrics import frame_confusion, matched_frame_accuracy

    sequence = args.sequence or Path(args.file).name.split(".")[0]
    truth_segments = read_labels(args.labels, sequence)
    names = sorted({s.label for s in truth_segments})
    X, fps, config, model, seconds = _run(args, n_labels=len(names))
    check_label_extent(args, truth_segments, sequence, X.shape[0])
    truth = frame_labels(truth_segments, X.shape[0])
    keep = truth >= 0  # unlabelled frames are not scored
    pred = model.labels_[keep]
    acc, mapping = matched_frame_accuracy(pred, truth[keep])
    C, clusters, labels = frame_confusion(pred, truth[keep])
    if args.plot:
        from streamseg.plotting.segments import plot_segments

        # clusters in the colour (and with the name) of the action they are matched to
        plot_segments(
            args.plot,
            X,
            model.segments_,
            fps=fps,
            truth=truth,
            truth_names=names,
            matching={int(c): int(t) for c, t in mapping.items()},
            method=_name(config),
            title=f"{sequence}: {_name(config)}, "
            f"{_k_text(model.n_clusters_, config)}: frame accuracy {acc:.3f}",
        )
    return evaluation(
        args,
        method="haca" if config.hierarchical else "aca",
        n_frames=int(X.shape[0]),
        fps=fps,
        n_clusters=model.n_clusters_,
        k_found=config.n_clusters is None,
        n_true_actions=len(names),
        scored_frames=int(keep.sum()),
        accuracy=acc,
        clusters=[int(c) for c in clusters],
        label_names=[names[int(i)] for i in labels],
        matching={str(int(c)): names[int(t)] for c, t in mapping.items()},
        confusion=C.tolist(),
        seconds=round(seconds, 3),
    )
