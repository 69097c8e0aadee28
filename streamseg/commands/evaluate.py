"""Score a segmentation against human labels (``streamseg eval FILE --labels CSV``), or every
method on every labelled recording under a folder (``streamseg eval --all DIR``)."""

from __future__ import annotations

from streamseg.commands.args import check_plot
from streamseg.commands.segment import add_common_arguments, check_options, emit
from streamseg.exceptions import ParameterError


def add_arguments(parser) -> None:
    add_common_arguments(parser, optional_file=True)
    parser.add_argument(
        "--all",
        metavar="DIR",
        help="score all of streamseg's methods on every recording with a label CSV "
        "under DIR and print one table (--skeleton: ASF for AMCs whose folder has none)",
    )
    parser.add_argument(
        "--runs", type=int, default=1, help="with --all: timed runs (median), default 1"
    )


def run(args) -> int:
    check_options(args)
    if args.all:
        return _run_all(args)
    if not args.file:
        raise ParameterError("eval needs FILE --labels CSV, or --all DIR")
    if not args.labels:
        raise ParameterError(
            "eval needs --labels CSV (sequence,start_frame,end_frame,action_label)"
        )
    check_plot(args.plot)
    emit(args, args.methods[args.method].evaluate(args))
    return 0


def _run_all(args) -> int:
    from streamseg import strict_json
    from streamseg.evaluation.corpus import (
        STREAMSEG_METHODS,
        discover,
        evaluate_all,
        format_table,
        json_row,
    )

    items = discover(args.all, skeleton=args.skeleton)
    if not items:
        raise ParameterError(f"no label CSVs with recordings under {args.all}")
    rows, _ = evaluate_all(items, STREAMSEG_METHODS, runs=args.runs)
    if args.json:
        print(strict_json.dumps({"schema": 1, "command": "eval --all", "folder": args.all,
                                 "rows": [{"recording": r, "method": m, **json_row(row)}
                                          for r, m, row in rows]}))
    else:
        print(format_table(rows))
    return 0
