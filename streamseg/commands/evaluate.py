"""Score a segmentation against human labels (``streamseg eval FILE --labels CSV``), or every
method on every labelled recording under a folder (``streamseg eval --all DIR``)."""

from __future__ import annotations

from streamseg.commands.args import check_plot
from streamseg.commands.segment import add_common_arguments, check_options, emit
from streamseg.exceptions import ParameterError


def add_arguments(parser) -> None:
    from streamseg.commands import eval_all

    add_common_arguments(parser, optional_file=True)
    eval_all.add_arguments(parser)


def run(args) -> int:
    if not args.all:
        args.method = args.method or "lof"
    if args.all and args.file:
        raise ParameterError(
            f"eval --all {args.all} scores every labelled recording under {args.all}, and "
            f"{args.file} would be ignored: give either --all DIR or FILE --labels CSV"
        )
    check_options(args)
    if args.all:
        from streamseg.commands import eval_all

        return eval_all.run(args)
    if not args.file:
        raise ParameterError("eval needs FILE --labels CSV, or --all DIR")
    if not args.labels:
        raise ParameterError(
            "eval needs --labels CSV (sequence,start_frame,end_frame,action_label)"
        )
    check_plot(args.plot)
    emit(args, args.methods[args.method].evaluate(args))
    return 0
