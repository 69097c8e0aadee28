"""streamseg: live motion-capture segmentation (cuts, action labels, repetitions).

Commands: info, segment, eval, batch (files); serve, replay, listen, view, keys, demo (the
daemon). Output of segment/eval --json: docs/output.md. Exit codes: 0 ok, 1 runtime
failure, 2 usage.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import math
import os
import sys
from pathlib import Path

from streamseg import strict_json
from streamseg.commands import METHODS, TOOLS
from streamseg.exceptions import ParameterError, RecordingError, SkeletonError, StreamsegError


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


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line (what is wrong, where the help is), exit code 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class _Formatter(argparse.RawDescriptionHelpFormatter):
    """Help with the default of every option that has one and does not already say it."""

    def _get_help_string(self, action):
        text = action.help or ""
        if ("default" not in text and action.default not in (None, False, argparse.SUPPRESS)
                and action.option_strings and not isinstance(action.default, bool)):
            text += " (default: %(default)s)"
        return text


def _plain(text: str) -> str:
    """A docstring line as help text: no Sphinx/RST markup."""
    return text.replace("``", "").replace(":func:", "").replace(":mod:", "").replace("`", "")


def frame_rate(text: str) -> float:
    """An ``--fps`` value: a finite number > 0 (argparse type; else a one-line usage error)."""
    try:
        fps = float(text)
    except ValueError:
        fps = float("nan")
    if not (math.isfinite(fps) and fps > 0):
        raise argparse.ArgumentTypeError(f"{text!r}: expected a frame rate in frames per "
                                         "second, a finite number > 0 (e.g. 120)")
    return fps


def endpoint(text: str) -> str:
    """A ZeroMQ endpoint to connect to (argparse type): ``tcp://HOST:PORT`` with a port in
    1..65535, or ``ipc://`` / ``inproc://``; else a one-line usage error (ZeroMQ would accept
    some bad ones and wait for a peer that can never come)."""
    scheme, sep, rest = text.partition("://")
    if sep and scheme in ("ipc", "inproc") and rest:
        return text
    host, _, port = rest.rpartition(":")
    if scheme == "tcp" and host and port.isdigit() and 1 <= int(port) <= 65535:
        return text
    raise argparse.ArgumentTypeError(f"{text!r}: expected an endpoint tcp://HOST:PORT with a "
                                     "port in 1..65535 (e.g. tcp://127.0.0.1:5560)")


def _add_input_arguments(p: argparse.ArgumentParser, optional: bool = False) -> None:
    p.add_argument(
        "file",
        nargs="?" if optional else None,
        help="recording (.amc[.gz], .bvh, .npz) or feature matrix (.npy, .csv)",
    )
    p.add_argument("--skeleton", help="ASF skeleton file (needed for AMC)")
    p.add_argument(
        "--fps",
        type=frame_rate,
        default=None,
        help="frame rate: needed for a feature matrix (.npy/.csv, rows per second); for a "
             "recording it replaces the file's own (AMC: 120)",
    )


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="streamseg", description=__doc__, formatter_class=_Formatter)
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("info", help="summarize a recording (or feature matrix) and its features",
                       formatter_class=_Formatter)
    _add_input_arguments(p)
    p.set_defaults(run=_run_info)

    methods = _available(METHODS)
    for name, helptext in (
        ("segment", "segment a recording offline (or --online)"),
        ("eval", "score a segmentation against human labels"),
    ):
        p = sub.add_parser(name, help=helptext, description=helptext,
                           formatter_class=_Formatter)
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
        owners = {}  # option dest -> the method whose option it is
        for mname, module in methods.items():
            before = {a.dest for a in p._actions}
            module.add_arguments(p.add_argument_group(f"{mname} options"))
            owners.update({a.dest: mname for a in p._actions if a.dest not in before})
        p.set_defaults(run=_run_segment if name == "segment" else _run_eval, methods=methods,
                       owners=owners)

    for name, module in _available(TOOLS).items():
        doc = _plain((module.__doc__ or "").strip())
        p = sub.add_parser(name, help=doc.splitlines()[0], description=doc,
                           formatter_class=_Formatter)
        module.add_arguments(p)
        p.set_defaults(run=module.run)
    return parser


def _run_info(args) -> int:
    from streamseg.commands.info import info

    print(info(args.file, skeleton=args.skeleton, fps=args.fps))
    return 0


def _check_options(args, parser_defaults: dict) -> None:
    """Warn about options that do nothing for the chosen method or command."""
    from streamseg.commands.output import warn

    for dest, owner in args.owners.items():
        if owner != args.method and getattr(args, dest) != parser_defaults.get(dest):
            flag = "--" + dest.replace("_", "-")
            warn(args, f"{flag} is a {owner} option: it does nothing with --method "
                       f"{args.method}")
    name = str(getattr(args, "file", "") or "").lower()
    if args.skeleton and name and not name.endswith((".amc", ".amc.gz")):
        warn(args, f"--skeleton does nothing for {Path(name).name}: only AMC files take an "
                   "ASF skeleton (BVH and .npz carry their own, matrices need none)")
    if args.command == "segment":
        for dest in ("labels", "sequence"):
            if getattr(args, dest):
                warn(args, f"--{dest} does nothing with segment (use eval to score against "
                           "labels)")


def _check_plot(args) -> None:
    check_plot(args.plot)


def check_plot(plot, need_matplotlib: bool = True) -> None:
    """Fail before the work, not after it, on a picture that cannot be written."""
    if not plot:
        return
    path = Path(plot)
    if path.suffix.lower() != ".png":
        raise ParameterError(f"--plot {plot}: expected a .png file name")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ParameterError(f"--plot {plot}: folder {folder} does not exist (create it "
                             "or choose another path)")
    if not os.access(folder, os.W_OK):
        raise ParameterError(f"--plot {plot}: folder {folder} is not writable")
    if not need_matplotlib:
        return
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise ParameterError("--plot needs matplotlib: pip install 'streamseg[plot]'") from None


def _run_segment(args) -> int:
    _check_plot(args)
    _emit(args, args.methods[args.method].segment(args))
    return 0


def _run_eval(args) -> int:
    if args.all:
        return _run_eval_all(args)
    if not args.file:
        raise ParameterError("eval needs FILE --labels CSV, or --all DIR")
    if not args.labels:
        raise ParameterError(
            "eval needs --labels CSV (sequence,start_frame,end_frame,action_label)"
        )
    _check_plot(args)
    _emit(args, args.methods[args.method].evaluate(args))
    return 0


def _run_eval_all(args) -> int:
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


def _emit(args, result: dict) -> None:
    from streamseg.commands import output

    if args.plot:
        result["plot"] = str(args.plot)
    if args.json:
        print(strict_json.dumps(result))
    elif result.get("command") == "segment":
        print(output.format_segmentation(result))
    elif result.get("command") == "eval":
        print(output.format_evaluation(result))
    else:
        _print_human(result)
    if args.plot:
        print(f"wrote {args.plot}", file=sys.stderr if args.json else sys.stdout)


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


def _failure(args, err: BaseException) -> int:
    """One line on stderr for a failure, and its exit code: 2 when what was asked cannot be
    done as asked (an option, an input file that is missing or unreadable), 1 when it failed
    while running (sockets, the daemon, an internal error)."""
    import zmq

    where = f"streamseg {getattr(args, 'command', '')}".rstrip()
    if isinstance(err, (ParameterError, SkeletonError, RecordingError)):
        print(f"{where}: error: {err}", file=sys.stderr)
        return 2
    if isinstance(err, (FileNotFoundError, IsADirectoryError, PermissionError)):
        print(f"{where}: error: {err.strerror}: {err.filename}", file=sys.stderr)
        return 2
    if isinstance(err, zmq.ZMQError):
        hint = ("another process uses the port: choose other ports (e.g. tcp://127.0.0.1:0 "
                "for a free one) or stop that process"
                if err.errno == zmq.EADDRINUSE else
                "endpoints look like tcp://127.0.0.1:5560" if err.errno == zmq.EINVAL else
                "check the endpoints and that the daemon runs")
        print(f"{where}: error: {err.strerror}: {hint}", file=sys.stderr)
        return 2 if err.errno == zmq.EINVAL else 1  # a malformed endpoint is a usage error
    if isinstance(err, (StreamsegError, OSError)):
        print(f"{where}: error: {err}", file=sys.stderr)
        return 1
    print(f"{where}: internal error: {type(err).__name__}: {err} (please report it; "
          "STREAMSEG_DEBUG=1 shows the traceback)", file=sys.stderr)
    return 1


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.command in ("segment", "eval"):
            sub = parser._subparsers._group_actions[0].choices[args.command]
            _check_options(args, {a.dest: a.default for a in sub._actions})
        return int(args.run(args) or 0)
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        # the reader went away (`streamseg info x | head`): not an error; stop quietly
        with contextlib.suppress(OSError):
            sys.stdout = open(os.devnull, "w")  # noqa: SIM115 (flushed at exit)
        return 0
    except Exception as err:
        if os.environ.get("STREAMSEG_DEBUG"):
            raise
        return _failure(args, err)



if __name__ == "__main__":
    sys.exit(main())
