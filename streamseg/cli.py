"""``streamseg`` command line: info | segment | eval | serve | replay | listen."""

from __future__ import annotations

import argparse
import importlib
import sys

from streamseg import strict_json
from streamseg.commands import METHODS, TOOLS
from streamseg.exceptions import StreamsegError


def _available(table: dict) -> dict:
    """Import the command modules that exist; a missing one is simply not offered."""
    found = {}
    for name, module in table.items():
        try:
            found[name] = importlib.import_module(module)
        except ModuleNotFoundError as err:
            if err.name != module:
                raise
    return found


def _add_input_arguments(p: argparse.ArgumentParser, optional: bool = False) -> None:
    p.add_argument(
        "file",
        nargs="?" if optional else None,
        help="recording (.amc[.gz], .bvh, .npz) or feature matrix (.npy, .csv)",
    )
    p.add_argument("--skeleton", help="ASF skeleton file (needed for AMC)")
    p.add_argument(
        "--fps",
        type=float,
        default=None,
        help="frame rate for a feature matrix (.npy/.csv, default 1) or an AMC (default 120)",
    )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="streamseg", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("info", help="summarize a recording and its features")
    _add_input_arguments(p)
    p.set_defaults(run=_run_info)

    methods = _available(METHODS)
    for name, helptext in (
        ("segment", "segment a recording offline (or --online)"),
        ("eval", "score a segmentation against human labels"),
    ):
        p = sub.add_parser(name, help=helptext)
        _add_input_arguments(p, optional=name == "eval")
        if name == "eval":
            p.add_argument(
                "--all",
                metavar="DIR",
                help="score all of streamseg's methods on every recording with a label CSV "
                "under DIR and print one table (--skeleton: ASF for AMCs whose folder has none)",
            )
            p.add_argument(
                "--runs", type=int, default=1, help="with --all: timed runs (median), default 1"
            )
        p.add_argument("--method", choices=sorted(methods), default="lof")
        p.add_argument("--json", action="store_true", help="print one JSON object")
        p.add_argument("--plot", metavar="PNG", help="write a picture of the result")
        p.add_argument(
            "--labels", metavar="CSV", help="human labels (sequence,start,end,label,...)"
        )
        p.add_argument("--sequence", help="label rows to use (default: the file's stem)")
        for mname, module in methods.items():
            module.add_arguments(p.add_argument_group(f"{mname} options"))
        p.set_defaults(run=_run_segment if name == "segment" else _run_eval, methods=methods)

    for name, module in _available(TOOLS).items():
        p = sub.add_parser(name, help=(module.__doc__ or "").strip().splitlines()[0])
        module.add_arguments(p)
        p.set_defaults(run=module.run)
    return parser


def _run_info(args) -> int:
    from streamseg.commands.info import info

    print(info(args.file, skeleton=args.skeleton, fps=args.fps))
    return 0


def _run_segment(args) -> int:
    _emit(args, args.methods[args.method].segment(args))
    return 0


def _run_eval(args) -> int:
    if args.all:
        return _run_eval_all(args)
    if not args.file:
        raise StreamsegError("eval needs FILE --labels CSV, or --all DIR")
    if not args.labels:
        raise StreamsegError(
            "eval needs --labels CSV (sequence,start_frame,end_frame,action_label)"
        )
    _emit(args, args.methods[args.method].evaluate(args))
    return 0


def _run_eval_all(args) -> int:
    from streamseg.evaluation.corpus import STREAMSEG_METHODS, discover, evaluate_all, format_table

    items = discover(args.all, skeleton=args.skeleton)
    if not items:
        raise StreamsegError(f"no label CSVs with recordings under {args.all}")
    rows, _ = evaluate_all(items, STREAMSEG_METHODS, runs=args.runs)
    if args.json:
        print(strict_json.dumps([{"recording": r, "method": m, **row}
                                 for r, m, row in rows]))
    else:
        print(format_table(rows))
    return 0


def _emit(args, result: dict) -> None:
    if args.json:
        print(strict_json.dumps(result))
    else:
        _print_human(result)


def _print_human(result: dict) -> None:
    for key, value in result.items():
        if isinstance(value, float):
            print(f"{key:>24}: {value:.4g}")
        elif (
            isinstance(value, (list, tuple)) and len(value) > 12 and not isinstance(value[0], list)
        ):
            print(f"{key:>24}: [{len(value)} items] {value[:12]} ...")
        elif key == "confusion":
            print(f"{key:>24}:")
            for row in value:
                print(" " * 26 + " ".join(f"{v:6d}" for v in row))
        else:
            print(f"{key:>24}: {value}")


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except StreamsegError as err:
        print(f"streamseg {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
