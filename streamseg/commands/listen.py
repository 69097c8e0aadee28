"""Subscribe to a daemon's events and print them (one JSON object per line with --jsonl).

With ``--control`` it first asks for the stream's current state (late-joiner catch-up), then,
when the daemon keeps an event log, every logged event of the stream since it opened (or
since ``--since N``; without ``--stream``, of every stream the log holds), then the live
events; ``--count N`` or ``--until-end`` make it stop.
Events carry per-stream sequence numbers: a hole (events lost, e.g. to the publish
high-water mark) is reported on stderr and, with ``--control``, filled from the log.
"""

from __future__ import annotations

import sys

import zmq

from streamseg import protocol, strict_json
from streamseg.client import (
    Refusal,
    count_in,
    fetch_since,
    handshake,
    listen,
    request,
    subscriber,
)
from streamseg.commands.listen_history import _every_history, _history, _not_fetched
from streamseg.commands.listen_lines import (
    CutBook,
    _json_state,
    _state_line,
    format_event,
    json_event,
    merged_runs,
)

__all__ = ["CutBook", "add_arguments", "format_event", "json_event", "merged_runs", "run"]


def add_arguments(parser) -> None:
    from streamseg.commands.args import endpoint

    parser.add_argument(
        "--from",
        dest="source",
        required=True,
        type=endpoint,
        metavar="ENDPOINT",
        help="daemon publish endpoint",
    )
    parser.add_argument("--stream", help="only this stream")
    parser.add_argument(
        "--type", dest="kind", choices=protocol.EVENT_TYPES, help="only this event type"
    )
    parser.add_argument("--jsonl", action="store_true", help="one JSON object per line")
    parser.add_argument(
        "--control", type=endpoint, metavar="ENDPOINT", help="ask for current state first"
    )
    parser.add_argument(
        "--since",
        type=int,
        metavar="N",
        help="first print the logged events with sequence numbers > N (each "
        "stream numbers its own) of --stream, or of every stream, one "
        "after another (needs --control; 0: all retained)",
    )
    stop = parser.add_mutually_exclusive_group()
    stop.add_argument("--count", type=int, metavar="N", help="stop after N events")
    stop.add_argument(
        "--until-end",
        action="store_true",
        help="stop when the stream (any stream without --stream) is closed",
    )
    parser.add_argument(
        "--curve-dir",
        metavar="DIR",
        help="CURVE keys made by `streamseg keys DIR` (client.key_secret, server.key)",
    )
    parser.add_argument(
        "--timeout",
        type=float,
        default=10.0,
        metavar="S",
        help="give up (exit 1) when no daemon is reached at --from for this "
        "many seconds, at the start or after the connection is lost; "
        "0: wait forever (default 10, as replay's --wait)",
    )
    parser.add_argument(
        "--idle",
        type=float,
        default=None,
        metavar="S",
        help="give up (exit 1) after this many seconds without an event",
    )


def _bad_option(args):
    """What is wrong with the options that need no daemon to check, or None."""
    if args.since is not None and not args.control:
        return (
            "--since needs --control ENDPOINT: the daemon's event log is read through it "
            "(e.g. listen --from EP --control EP --since 0)"
        )
    if args.since is not None and args.since < 0:
        return f"--since {args.since} is invalid: expected a sequence number >= 0 (0: all)"
    if args.count is not None and args.count < 1:
        return f"--count {args.count} is invalid: expected a number of events >= 1"
    if not args.timeout >= 0:
        return f"--timeout {args.timeout:g} is invalid: expected seconds >= 0 (0: forever)"
    if args.idle is not None and not args.idle > 0:
        return f"--idle {args.idle:g} is invalid: expected seconds > 0"
    return None


def run(args) -> int:
    problem = _bad_option(args)
    if problem:
        print(f"streamseg listen: error: {problem}", file=sys.stderr)
        return 2
    curve = None
    if args.curve_dir:
        from streamseg.daemon.security import ClientKeys

        curve = ClientKeys.load(args.curve_dir)
    ctx = zmq.Context.instance()
    # the SUB socket's monitor, attached before it connects: it notices a refused key (which
    # nothing else would without --control) and whether a daemon is there at all
    sock, monitor = subscriber(
        args.source,
        args.stream,
        args.kind,
        ctx,
        curve=curve,
        monitor=Refusal.EVENTS | zmq.EVENT_DISCONNECTED,
    )
    if args.stream and args.control and args.kind is None:
        # the heartbeats carry each stream's last event number: a loss at the tail shows
        sock.setsockopt(zmq.SUBSCRIBE, protocol.topic("stats", None))
    wait_s = args.timeout or None  # 0: wait for the daemon forever
    out = sys.stdout
    since, backlog, pending = None, [], []

    def on_hole(key, first, end):
        where = f"events {first}..{end - 1} of stream {key}"
        if not args.control or key == protocol.DAEMON_WIDE:
            print(
                f"streamseg listen: hole: {where} were missed ({end - first})"
                + ("" if args.control else "; give --control to fetch them"),
                file=sys.stderr,
            )
            return ()
        skipped = []
        try:
            evs = fetch_since(
                args.control, key, first - 1, ctx, upto=end, curve=curve, skipped=skipped
            )
        except (LookupError, TimeoutError) as err:
            print(
                f"streamseg listen: hole: {where} were missed ({end - first}); cannot "
                f"fetch them: {err}",
                file=sys.stderr,
            )
            return ()
        print(
            f"streamseg listen: hole: {where}: {len(evs)} fetched from the event log"
            + _not_fetched(end - first - len(evs), count_in(skipped, first, end - 1)),
            file=sys.stderr,
        )
        return [e for e in evs if args.kind is None or e.type == args.kind]

    try:
        if args.control:
            # the subscription is live before the snapshot: nothing falls between them
            pending = handshake(sock, args.control, ctx, curve=curve, timeout=wait_s or 30.0)
            if args.stream:
                since = request(args.control, "state", ctx, curve=curve, stream=args.stream)
                if since.get("ok"):
                    state = {
                        "type": "state",
                        **{k: v for k, v in since.items() if k not in ("ok", "v")},
                    }
                    text = (
                        strict_json.dumps(_json_state(state)) if args.jsonl else _state_line(state)
                    )
                    out.write(text + "\n")
                    backlog = _history(args, since, ctx, curve)
                    if backlog is not None:
                        since = None  # the log has every event: filter by sequence number
                    elif args.until_end and since.get("closed"):
                        print(
                            f"streamseg listen: stream {args.stream} is already closed "
                            f"({since['closed']}): nothing to wait for (without "
                            "--until-end, listen waits for it to be announced again)",
                            file=sys.stderr,
                        )
                        return 0
                elif args.since is not None:
                    backlog = _history(args, {"seq_base": args.since}, ctx, curve)
                    since = None
                else:  # not open (yet): say so where the events go, then follow it
                    state = {"type": "state", "stream": args.stream, "open": False}
                    out.write(
                        (
                            strict_json.dumps(state)
                            if args.jsonl
                            else f"[{args.stream}] not open yet: waiting for it"
                        )
                        + "\n"
                    )
                    since = None
            else:
                streams = request(args.control, "streams", ctx, curve=curve)
                line = {"type": "streams", "streams": streams.get("streams", [])}
                out.write(
                    (
                        strict_json.dumps(line)
                        if args.jsonl
                        else f"[*] streams  {[s['stream'] for s in line['streams']]}"
                    )
                    + "\n"
                )
                if args.since is not None:
                    backlog = _every_history(args, ctx, curve)
            out.flush()
        book = CutBook()
        for ev in listen(
            sock,
            stream=args.stream,
            count=args.count,
            until_end=args.until_end,
            timeout=args.idle,
            since=since,
            backlog=backlog or (),
            on_hole=on_hole if args.kind is None else None,
            pending=pending,
            monitor=monitor,
            on_monitor=Refusal(args.source, curve).check,
            connect_timeout=wait_s,
            endpoint=args.source,
            on_waiting=lambda text: print(f"streamseg listen: {text}", file=sys.stderr, flush=True),
        ):
            line = book.apply(ev)  # the stream's cuts after its withdraws, at its close
            if line is not None:
                out.write(
                    (
                        strict_json.dumps(line)
                        if args.jsonl
                        else f"[{line['stream']}] cuts     {len(line['frames'])} after "
                        f"{line['withdrawn']} withdrawn: {line['frames']}"
                    )
                    + "\n"
                )
            text = strict_json.dumps(json_event(ev)) if args.jsonl else format_event(ev)
            out.write(text + "\n")
            out.flush()
    except TimeoutError as err:
        print(f"streamseg listen: {err}", file=sys.stderr)
        return 1
    finally:
        sock.disable_monitor()
        monitor.close(linger=0)
        sock.close()
    return 0
