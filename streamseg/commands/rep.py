"""``streamseg segment|eval FILE --method rep``: cut a repetitive exercise into repetitions.

FILE is a recording with Acclaim joint names (CMU/HDM05 AMC + ``--skeleton``; the four-pass
kinematic UKF turns it into joint angles) or a matrix ``.npy``/``.csv`` of kinematic parameter
trajectories (rows = frames, radians; ``--fps`` required). Method: Wang et al. 2015.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

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


def _config(args) -> RepetitionConfig:
    return RepetitionConfig(power_ratio=args.rep_power_ratio,
                            bandpass_width_cycles=args.rep_band_width,
                            min_cycles=args.rep_min_cycles, max_frequency_hz=args.rep_max_hz,
                            position_noise=args.rep_noise, ukf_passes=args.rep_passes,
                            seed=args.rep_seed)


def _run(args):
    from streamseg.io.matrix import MATRIX_SUFFIXES, read_matrix
    from streamseg.offline.repetition import RepetitionSegmenter

    cfg = _config(args)
    seg = RepetitionSegmenter(cfg)
    t0 = time.perf_counter()
    if Path(args.file).suffix.lower() in MATRIX_SUFFIXES:
        if args.fps is None:
            raise ParameterError("--fps is required with a parameter matrix (.npy/.csv): "
                                 "the frame rate of its rows")
        seg.fit(read_matrix(args.file), fps=float(args.fps))
    else:
        from streamseg.io import read

        seg.fit(read(args.file, args.skeleton, fps=args.fps))
    return cfg, seg, time.perf_counter() - t0


def segment(args) -> dict:
    """Repetitions of ``args.file`` as the JSON-able result the issue specifies."""
    cfg, seg, seconds = _run(args)
    if args.plot:
        from streamseg.plotting.repetitions import plot_repetitions

        plot_repetitions(args.plot, seg)
    a = seg.analysis_
    # the live counter's "repetitive" test, applied to the whole input: a multi-exercise
    # routine or a non-repetitive take gets counted all the same, so say so
    repetitive = bool(a.concentration >= cfg.repetitive_ratio)
    if not repetitive:
        print(f"streamseg segment: warning: {Path(args.file).name} does not look repetitive "
              f"(power concentration {a.concentration:.2f} < {cfg.repetitive_ratio}); the count "
              "assumes one repeated action: cut the take into exercises first", file=sys.stderr)
    return {
        "n_frames": int(seg.n_frames_),
        "fps": float(seg.fps_),
        "method": "rep",
        "count": int(seg.count_),
        "repetitive": repetitive,
        "repetitions": [{"start": int(s), "end": int(e)} for s, e in seg.repetitions_],
        "primary_frequency_hz": float(seg.primary_frequency_hz_),
        "params": {
            "selected": [seg.param_names_[i] for i in a.selected],
            "k_star": int(a.k_star),
            "n_candidates": int(a.candidates.size),
            "concentration": round(float(a.concentration), 4),
            "power_ratio": cfg.power_ratio,
            "bandpass_width_cycles": cfg.bandpass_width_cycles,
            "ukf_passes": cfg.ukf_passes,
            "seconds": round(seconds, 3),
        },
    }


def evaluate(args) -> dict:
    """Accuracy alpha (eq. 15) and count error against ``args.labels``.

    The label rows of the sequence must be one row per repetition (start, end of each
    repetition). Labels of whole exercise blocks (one row per exercise, like the CMU exercise
    routines' labels.csv) do not mark repetitions: alpha is then meaningless; use
    ``segment`` on each block instead.
    """
    from streamseg.evaluation.labels import read_labels
    from streamseg.evaluation.metrics import count_error, repetition_accuracy

    cfg, seg, seconds = _run(args)
    sequence = args.sequence or Path(args.file).name.split(".")[0]
    truth = [(s.start, s.end) for s in read_labels(args.labels, sequence)]
    if args.plot:
        from streamseg.plotting.repetitions import plot_repetitions

        plot_repetitions(args.plot, seg, truth=truth)
    return {
        "alpha": repetition_accuracy(seg.repetitions_, truth),
        "count": int(seg.count_),
        "true_count": len(truth),
        "count_error": count_error(seg.count_, len(truth)),
        "primary_frequency_hz": float(seg.primary_frequency_hz_),
        "seconds": round(seconds, 3),
        "note": "labels are read as one row per repetition (eq. 15 compares the i-th found and "
                "true repetition lengths)",
    }
