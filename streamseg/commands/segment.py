"""Segment a recording offline (or ``--online``) with one of streamseg's methods.

``streamseg segment FILE --method lof|aca|rep``; ``--json`` prints one object
(``docs/output.md``). Each method's own options come from its module in
:data:`streamseg.commands.METHODS`; ``streamseg eval`` (:mod:`streamseg.commands.evaluate`)
shares them.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

from streamseg.commands import METHODS
from streamseg.commands.args import add_input_arguments, check_plot


def available_methods() -> dict:
    """Import the method modules that exist; a missing one is simply not offered."""
    found = {}
    for name, module in METHODS.items():
        try:
            found[name] = importlib.import_module(module)
        except ModuleNotFoundError as err:
            if err.name != module:
                raise
    return found


def add_common_arguments(p, *, optional_file: bool = False, write_events: bool = False) -> None:
    """The options segment and eval share, then every method's own group."""
    add_input_arguments(p, optional=optional_file, write_events=write_events)
    methods = available_methods()
    p.add_argument(
        "--method",
        choices=sorted(methods),
        default=None,
        help="default: lof (with eval --all: lof and aca)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--plot", metavar="PNG", help="write a picture of the result")
    if optional_file:  # eval: segment has no labels to score against
        p.add_argument(
            "--labels", metavar="CSV", help="human labels (sequence,start,end,label,...)"
        )
        p.add_argument("--sequence", help="label rows to use (default: the file's stem)")
    owners = {}  # option dest -> the method whose option it is
    for mname, module in methods.items():
        before = {a.dest for a in p._actions}
        module.add_arguments(p.add_argument_group(f"{mname} options"))
        owners.update({a.dest: mname for a in p._actions if a.dest not in before})
    p.set_defaults(
        methods=methods, owners=owners, option_defaults={a.dest: a.default for a in p._actions}
    )


def add_arguments(parser) -> None:
    add_common_arguments(parser, write_events=True)


def check_options(args) -> None:
    """Warn about options that do nothing for the chosen method or command."""
    from streamseg.commands.output import warn

    for dest, owner in args.owners.items():
        if owner != (args.method or "lof") and getattr(args, dest) != args.option_defaults.get(
            dest
        ):
            flag = "--" + dest.replace("_", "-")
            warn(args, f"{flag} is a {owner} option: it does nothing with --method {args.method}")
    name = str(getattr(args, "file", "") or "").lower()
    if args.skeleton and name and not name.endswith((".amc", ".amc.gz")):
        warn(
            args,
            f"--skeleton does nothing for {Path(name).name}: only AMC files take an "
            "ASF skeleton (BVH, C3D and .npz carry their own, positions are named by "
            "their header or --joints, matrices need none)",
        )


def run(args) -> int:
    from streamseg.commands.inputs import check_write_events, write_events

    args.method = args.method or "lof"
    check_options(args)
    check_plot(args.plot)
    check_write_events(args)
    result = args.methods[args.method].segment(args)
    if args.write_events:
        write_events(args, result)
    emit(args, result)
    return 0


def emit(args, result: dict) -> None:
    """Print a segment/eval result (JSON or text) and say where the picture went."""
    from streamseg import strict_json
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
