"""``streamseg eval --all DIR``: every labelled recording under DIR, one table per method and set.

With the bundled ``data/`` folder that is the 27 labelled recordings of ``docs/results.md``
(:mod:`streamseg.evaluation.labelled_sets`): the CMU takes with label CSVs and the sequences
joined from the CMU 02 and HDM05 clips. The options of ``--method lof`` (``--preset``,
``--delay``, ...) apply to its runs, so each row of a results table is one command.
"""

from __future__ import annotations

import math

from streamseg.exceptions import ParameterError


def add_arguments(parser) -> None:
    """The ``--all`` options of ``eval``."""
    parser.add_argument(
        "--all",
        metavar="DIR",
        help="score every labelled recording under DIR (data/: also the sequences joined from "
        "its clips) and print one table; --method lof or aca keeps one method's rows",
    )
    parser.add_argument(
        "--sets",
        metavar="NAMES",
        help="with --all: only these sets, comma-separated (cmu, cmu02, hdm, "
        "fresh, fresh2; files: recordings of other label CSVs)",
    )
    parser.add_argument(
        "--chosen-on",
        metavar="NAMES",
        help="with --all: recordings the parameters were chosen on, "
        "comma-separated: the summary adds a mean over all the others",
    )
    parser.add_argument(
        "--runs",
        type=int,
        default=1,
        help="with --all: timed runs per recording (median), default 1",
    )


def _names(text) -> list[str]:
    return [t.strip() for t in (text or "").split(",") if t.strip()]


def methods_for(args) -> dict:
    """``name -> callable(item, fps) -> Prediction`` for ``args.method`` (None: lof and aca),
    with the LOF options given on the command line."""
    from streamseg.commands.lof import config_from_args
    from streamseg.evaluation.corpus import STREAMSEG_METHODS, lof_prediction
    from streamseg.offline.lof import lof_features

    if args.method == "rep":
        raise ParameterError(
            "eval --all scores cuts and labels (--method lof or aca); the "
            "repetition tables come from benchmarks/repetitions.py"
        )
    out = {}
    if args.method in (None, "lof"):
        config = config_from_args(args)
        out["LOF streaming"] = lambda item, fps: lof_prediction(
            lof_features(item.recording, config), fps, True, config
        )
        out["LOF offline"] = lambda item, fps: lof_prediction(
            lof_features(item.recording, config), fps, False, config
        )
    if args.method in (None, "aca"):
        out.update({k: v for k, v in STREAMSEG_METHODS.items() if "ACA" in k})
    return out


def _mean(values) -> float:
    import numpy as np

    vals = [v for v in values if not (isinstance(v, float) and math.isnan(v))]
    return float(np.mean(vals)) if vals else float("nan")


def summarise(rows, preds: dict, groups: dict, fps: dict, chosen_on=()) -> list[dict]:
    """Per method: one summary per set, over all, and over the recordings not chosen on.

    Parameters
    ----------
    rows : list of (recording, method, score row)
    preds : dict of (recording, method) -> Prediction (for the cuts' latencies)
    groups : dict of recording -> set name
    fps : dict of recording -> frames per second (latencies are reported in seconds)
    chosen_on : iterable of str

    Returns
    -------
    list of dict
        ``method``, ``set``, ``n``, mean ``f1``, ``f1_1s``, ``covering``, ``accuracy``,
        ``latency_median_s`` / ``latency_max_s`` (over every cut of the recordings),
        ``worst`` (the recording with the lowest F1) and ``worst_f1``.
    """
    import numpy as np

    chosen = set(chosen_on)
    out = []
    for method in dict.fromkeys(m for _, m, _ in rows):
        ok = [(r, row) for r, m, row in rows if m == method and "error" not in row]
        subsets = [
            (s, [x for x in ok if groups[x[0]] == s])
            for s in dict.fromkeys(groups[r] for r, _ in ok)
        ]
        subsets.append(("all", ok))
        if chosen:
            subsets.append(
                (
                    f"held out (all but {', '.join(sorted(chosen))})",
                    [x for x in ok if x[0] not in chosen],
                )
            )
        for name, part in subsets:
            if not part:
                continue
            worst = min(part, key=lambda x: x[1]["F1"])
            lats = [lat / fps[r] for r, _ in part for lat in (preds[r, method].latencies or [])]
            out.append(
                {
                    "method": method,
                    "set": name,
                    "n": len(part),
                    "f1": _mean(row["F1"] for _, row in part),
                    "f1_1s": _mean(row["F1@1s"] for _, row in part),
                    "covering": _mean(row["cover"] for _, row in part),
                    "accuracy": _mean(row["acc"] for _, row in part),
                    "latency_median_s": float(np.median(lats)) if lats else float("nan"),
                    "latency_max_s": float(np.max(lats)) if lats else float("nan"),
                    "worst": worst[0],
                    "worst_f1": worst[1]["F1"],
                }
            )
    return out


def format_summary(summary: list[dict]) -> str:
    """The summary as a markdown table."""

    def num(v, digits=3):
        return "" if isinstance(v, float) and math.isnan(v) else f"{v:.{digits}f}"

    lines = [
        "| method | set | recordings | F1 | F1@1s | cover | acc | latency median / max s "
        "| worst F1 |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for s in summary:
        lat = (
            ""
            if math.isnan(s["latency_median_s"])
            else f"{num(s['latency_median_s'], 2)} / {num(s['latency_max_s'], 2)}"
        )
        lines.append(
            f"| {s['method']} | {s['set']} | {s['n']} | {num(s['f1'])} | "
            f"{num(s['f1_1s'])} | {num(s['covering'])} | {num(s['accuracy'])} | {lat} "
            f"| {num(s['worst_f1'], 2)} ({s['worst']}) |"
        )
    return "\n".join(lines)


def run(args) -> int:
    """Score, print the per-recording table and the summary (or one JSON object)."""
    from streamseg import strict_json
    from streamseg.evaluation.corpus import evaluate_all, format_table, json_row
    from streamseg.evaluation.labelled_sets import labelled_sets

    if args.runs < 1:
        raise ParameterError(f"--runs {args.runs}: expected at least 1")
    methods = methods_for(args)
    sets = _names(args.sets) or None
    markers = None
    if args.markers:  # read once, for every C3D and TRC under the folder
        from streamseg.skeleton.marker_map import load_marker_map

        markers = load_marker_map(args.markers)
    items = labelled_sets(args.all, sets=sets, skeleton=args.skeleton, markers=markers)
    if not items:
        raise ParameterError(f"no label CSVs with recordings under {args.all}")
    chosen = _names(args.chosen_on)
    unknown = [c for c in chosen if c not in {i.name for i in items}]
    if unknown:
        raise ParameterError(
            f"--chosen-on {', '.join(unknown)}: not among the recordings "
            "scored (names as in the table's first column)"
        )
    rows, preds = evaluate_all(items, methods, runs=args.runs)
    groups = {i.name: i.group for i in items}
    fps = {i.name: i.recording.fps for i in items}
    summary = summarise(rows, preds, groups, fps, chosen)
    if args.json:
        print(
            strict_json.dumps(
                {
                    "schema": 1,
                    "command": "eval --all",
                    "folder": str(args.all),
                    "rows": [
                        {"recording": r, "set": groups[r], "method": m, **json_row(row)}
                        for r, m, row in rows
                    ],
                    "summary": summary,
                }
            )
        )
    else:
        print(format_table(rows, means=False))
        print()
        print(format_summary(summary))
    return 0
