"""What ``streamseg listen`` reads back from the daemon's event log (``--control``, ``--since``)
before it follows the live events, and what it says on stderr of what the log cannot give."""

from __future__ import annotations

import sys

from streamseg.client import count_in, fetch_since, request


def _history(args, state: dict, ctx, curve=None):
    """The logged events of the stream since ``--since`` (or since it opened, for a stream
    that is open), ``--type`` applied; None when there is nothing to fetch or no log."""
    if args.since is None and (state.get("closed") or "seq_base" not in state):
        return None
    start = args.since if args.since is not None else state["seq_base"]
    try:
        return _stream_history(args, args.stream, start, ctx, curve, say_newest=True)
    except (LookupError, TimeoutError) as err:
        if args.since is not None:
            print(f"streamseg listen: --since: {err}", file=sys.stderr)
        return None


def _every_history(args, ctx, curve=None) -> list:
    """``--since N`` without ``--stream``: the logged events above N of every stream id the
    log holds (``*`` for daemon-wide events), stream by stream in the order of their oldest
    event held, ``--type`` applied."""
    try:
        reply = request(args.control, "logged", ctx, curve=curve)
        if not reply.get("ok"):
            raise LookupError(reply.get("error"))
        out = []
        for row in reply["streams"]:
            if row["last"] > args.since:
                out += _stream_history(args, row["stream"], args.since, ctx, curve)
    except (LookupError, TimeoutError) as err:
        print(f"streamseg listen: --since: {err}", file=sys.stderr)
        return []
    if reply.get("more"):
        print(
            f"streamseg listen: --since: the log holds more stream ids than one reply "
            f"lists; fetched those of the first {len(reply['streams'])}",
            file=sys.stderr,
        )
    if not reply["streams"] or max(r["last"] for r in reply["streams"]) <= args.since:
        newest = max((r["last"] for r in reply["streams"]), default=0)
        print(
            f"streamseg listen: --since {args.since}: the newest event number of any "
            f"stream is {newest}: nothing to fetch, following live events",
            file=sys.stderr,
        )
    return out


def _stream_history(
    args, stream: str, start: int, ctx, curve=None, say_newest: bool = False
) -> list:
    """The logged events of ``stream`` above ``start``, ``--type`` applied; what the log
    cannot give (retention, numbers skipped at a restart) is said on stderr. Raises
    LookupError (no log) and TimeoutError."""
    said, skipped = [], []

    def say_range(first, last):  # what the log cannot give, said rather than left silent
        if say_newest and args.since is not None and args.since > last:
            newest = f"is {last}" if last else "does not exist (no event logged)"
            print(
                f"streamseg listen: --since {args.since}: the newest event of stream "
                f"{stream} {newest}: nothing to fetch, following live events",
                file=sys.stderr,
            )
        elif first > start + 1:
            said.append((start + 1, first - 1))

    evs = fetch_since(
        args.control, stream, start, ctx, curve=curve, on_range=say_range, skipped=skipped
    )
    for lo, hi in said:
        n_skipped = count_in(skipped, lo, hi)
        if n_skipped == hi - lo + 1:
            print(
                f"streamseg listen: numbers {lo}..{hi} of stream {stream} were "
                "skipped at a restart after a crash (no event had them); fetching from "
                f"{hi + 1}",
                file=sys.stderr,
            )
        else:
            print(
                f"streamseg listen: events {lo}..{hi} of stream {stream} are no "
                "longer in the event log (retention: --log-max-mb, --log-max-days"
                + (f"; {n_skipped} of the numbers were skipped at a restart" if n_skipped else "")
                + f"); fetching from {hi + 1}",
                file=sys.stderr,
            )
    return [e for e in evs if args.kind is None or e.type == args.kind]


def _not_fetched(missing: int, skipped: int) -> str:
    """What a hole report says of the numbers the log did not give."""
    if not missing:
        return ""
    text = (
        (f"; {skipped} numbers were skipped at a restart after a crash (no event had them)")
        if skipped
        else ""
    )
    if missing > skipped:
        text += (
            f"; {missing - skipped} events are not in the log (retention, or a disk "
            "that refused them: the daemon's `error` events say)"
        )
    return text
