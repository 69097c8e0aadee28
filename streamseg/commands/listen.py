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
import time

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


def json_event(ev) -> dict:
    """An event as ``listen --jsonl`` prints it (docs/output.md): its fields, with segments
    as ``{"start", "end", "label"}`` objects like ``segment --json`` prints them."""
    out = protocol.to_json(ev)
    if ev.type == "segments":
        out["segments"] = [
            {"start": int(a), "end": int(b), "label": int(lab)} for a, b, lab in ev.segments
        ]
    return out


def _json_state(state: dict) -> dict:
    segs = state.get("segments")
    if isinstance(segs, dict) and isinstance(segs.get("segments"), list):
        segs = dict(
            segs, segments=[{"start": a, "end": b, "label": lab} for a, b, lab in segs["segments"]]
        )
        state = dict(state, segments=segs)
    return state


def merged_runs(segments) -> list:
    """Consecutive segments of one label joined: ACA's segments are cycles of an action, a
    reader wants the actions."""
    runs = []
    for a, b, lab in segments:
        if runs and runs[-1][2] == lab and runs[-1][1] == a:
            runs[-1] = (runs[-1][0], b, lab)
        else:
            runs.append((a, b, lab))
    return runs


def format_event(ev) -> str:
    """One readable line per event."""
    t = ev.type
    if t == "cut":
        ms = f".{int(ev.time * 1000) % 1000:03d}"
        when = (
            time.strftime("%H:%M:%S", time.gmtime(ev.time)) + ms + "Z"
            if ev.time > 1e8
            else f"{ev.time:9.3f}s"
        )  # a sender clock, or stream seconds
        return (
            f"[{ev.stream}] cut      frame {ev.frame:7d}  t={when}  score "
            f"{ev.score:6.2f}  (emitted at frame {ev.emitted_at}, "
            f"{'pending' if ev.pending else 'provisional'})"
        )
    if t == "confirm":
        return (
            f"[{ev.stream}] confirm  frame {ev.frame:7d}  the pending cut stands "
            f"(at frame {ev.emitted_at})"
        )
    if t == "withdraw":
        why = "moved: a cut nearby follows" if ev.moved else "no cut there"
        return (
            f"[{ev.stream}] withdraw frame {ev.frame:7d}  the pending cut is taken back "
            f"(at frame {ev.emitted_at}, {why})"
        )
    if t == "segments":
        runs = merged_runs(ev.segments)
        segs = " ".join(f"{a}-{b}:{lab}" for a, b, lab in runs[:12])
        more = f" +{len(runs) - 12}" if len(runs) > 12 else ""
        return (
            f"[{ev.stream}] relabel  rev {ev.revision:3d}  frames {ev.start}-{ev.end}  "
            f"{len(runs)} runs of {len({r[2] for r in runs})} labels"
            f"{' FINAL' if ev.final else ''} ({ev.elapsed * 1000:.0f} ms): {segs}{more}"
        )
    if t == "error":
        return f"[{ev.stream or '-'}] error    {ev.reason} x{ev.count}: {ev.message}"
    if t == "gap":
        return f"[{ev.stream}] gap      frames {ev.expected}..{ev.got - 1} missing"
    if t == "rep":
        return f"[{ev.stream}] rep      #{ev.count} frames {ev.start}-{ev.end}"
    if t == "closed":
        return f"[{ev.stream}] closed   ({ev.reason}) after {ev.frames} frames"
    if t == "stats":
        tot = ev.totals
        return (
            f"[*] stats    up {ev.uptime:.1f}s  streams {tot.get('streams', 0)}  frames "
            f"{tot.get('frames', 0)}  events {tot.get('events', 0)}  errors "
            f"{tot.get('errors', 0)}"
        )
    return repr(ev)


class CutBook:
    """Each stream's cuts with its ``withdraw`` events applied (two-stage detector).

    :meth:`apply` returns, at a stream's ``closed`` event when the stream had pending cuts,
    the line ``{"type": "cuts", "stream", "frames", "withdrawn"}`` listing its cuts minus
    the withdrawn ones (the final cuts, in frame order); else None.
    """

    def __init__(self):
        self.cuts: dict = {}  # stream -> frames (emission order)
        self.withdrawn: dict = {}  # stream -> count; present once a pending cut was seen

    def apply(self, ev):
        stream = getattr(ev, "stream", None)
        if ev.type == "cut":
            self.cuts.setdefault(stream, []).append(ev.frame)
            if ev.pending:
                self.withdrawn.setdefault(stream, 0)
        elif ev.type == "withdraw":
            frames = self.cuts.get(stream, [])
            if ev.frame in frames:
                del frames[len(frames) - 1 - frames[::-1].index(ev.frame)]
                self.withdrawn[stream] = self.withdrawn.get(stream, 0) + 1
        elif ev.type == "closed":
            frames = self.cuts.pop(stream, [])
            if stream in self.withdrawn:
                return {
                    "type": "cuts",
                    "stream": stream,
                    "frames": sorted(frames),
                    "withdrawn": self.withdrawn.pop(stream),
                }
        return None


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


def _state_line(state: dict) -> str:
    seg = state.get("segments")
    if seg is None:
        segs = "none"
    else:  # in the unit of the relabel lines: runs of one label
        runs = merged_runs(seg["segments"])
        segs = (
            f"{len(runs)} runs of {len({r[2] for r in runs})} labels over "
            f"{seg['start']}-{seg['end']}"
        )
    return (
        f"[{state['stream']}] state    frame {state['frame']}  revision {state['revision']}  "
        f"{segs}  + {len(state['cuts'])} newer cuts"
        + (f"  closed ({state['closed']})" if state.get("closed") else "")
    )
