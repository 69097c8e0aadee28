"""Replay a recording as a live stream to a daemon's ingest endpoint.

Announces the stream, sends N frames per packet at real time times ``--speed`` (``0``: as fast
as the daemon takes them; a PUSH socket waits when the daemon's queue is full), then ends it.
With no daemon listening it says it is waiting and gives up after ``--wait`` seconds; Ctrl-C
(SIGINT) or SIGTERM sends ``end`` before it exits, so the daemon closes the stream at once.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

from streamseg import protocol
from streamseg.client import sending_context
from streamseg.commands.replay_publish import REANNOUNCE_S, _publish_run, publish
from streamseg.commands.replay_push import (
    Interrupted,
    NoDaemon,
    announce_of,
    replay,
    stream_id,
)
from streamseg.exceptions import ParameterError
from streamseg.recording import UP_AXES

__all__ = [
    "REANNOUNCE_S",
    "Interrupted",
    "NoDaemon",
    "add_arguments",
    "announce_of",
    "publish",
    "replay",
    "run",
    "stream_id",
]


def add_arguments(parser) -> None:
    from streamseg.commands.args import endpoint, frame_rate
    from streamseg.commands.inputs import add_source_arguments

    parser.add_argument(
        "file", help="recording (.amc[.gz], .bvh, .c3d, .trc, .npz; joint positions .csv/.npy/.npz)"
    )
    parser.add_argument("--skeleton", help="ASF skeleton file (needed for AMC)")
    parser.add_argument(
        "--fps",
        type=frame_rate,
        default=None,
        help="frame rate of positions without a time column; replaces the file's own",
    )
    add_source_arguments(parser)
    parser.add_argument(
        "--to",
        type=endpoint,
        metavar="ENDPOINT",
        help="daemon ingest endpoint (PUSH: the daemon's pace)",
    )
    parser.add_argument(
        "--publish",
        type=endpoint,
        metavar="ENDPOINT",
        help="instead of --to: publish the stream on this endpoint (a PUB "
        "socket bound here), as a mocap bridge does, for daemons "
        "started with --subscribe ENDPOINT; the announce is repeated "
        "every second for subscribers that join late",
    )
    parser.add_argument("--speed", type=float, default=1.0, help="times real time; 0 = max")
    parser.add_argument("--stream", help="stream id (default: the file's stem)")
    parser.add_argument("--batch", type=int, default=1, metavar="N", help="frames per packet")
    parser.add_argument("--loop", action="store_true", help="start over at the end, forever")
    parser.add_argument("--float32", action="store_true", help="send float32 positions")
    parser.add_argument(
        "--wait",
        type=float,
        default=10.0,
        metavar="S",
        help="give up when the daemon takes no packet for S seconds (default 10)",
    )
    parser.add_argument(
        "--curve-dir",
        metavar="DIR",
        help="CURVE keys made by `streamseg keys DIR` (client.key_secret, server.key)",
    )
    parser.add_argument(
        "--up",
        choices=UP_AXES,
        help="announce this world up axis (default: the format's, y for AMC/BVH)",
    )
    parser.add_argument(
        "--labels",
        metavar="CSV",
        help="announce this human label file (sequence,start_frame,end_frame,"
        "action_label): `streamseg view` overlays it and shows agreement",
    )
    parser.add_argument(
        "--labels-sequence",
        metavar="NAME",
        help="the label file's sequence to use (default: the file's stem)",
    )


def run(args) -> int:
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return _run(args)
    # SIGTERM (systemd, timeout, kill) ends the stream like Ctrl-C: `end` goes out first
    previous = signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        return _run(args)
    finally:
        signal.signal(signal.SIGTERM, previous)


def _run(args) -> int:
    # the command's own context: it ends only once the queued packets are out (or the
    # linger is over), never losing the last ones as an exit from Context.instance() does
    with sending_context() as ctx:
        return _replay_command(args, ctx)


def _replay_command(args, ctx) -> int:
    from streamseg.commands.inputs import read_recording

    # what the daemon would refuse, refused here: it would only log it, and we would say "sent"
    if args.stream is not None and not protocol.valid_stream_id(args.stream):
        raise ParameterError(
            f"--stream {args.stream!r} is not a valid stream id: use 1-128 "
            "characters of A-Z a-z 0-9 _ . : @ + = - (docs/protocol.md)"
        )
    if not args.wait > 0:
        raise ParameterError(f"--wait {args.wait:g} is invalid: expected seconds > 0")
    if (args.to is None) == (args.publish is None):
        raise ParameterError(
            "give --to ENDPOINT (a daemon's ingest) or --publish ENDPOINT "
            "(publish for daemons that subscribe), one of them"
        )
    if args.labels:  # the view reads them later, elsewhere: a wrong path is said now
        from streamseg.evaluation.labels import read_labels

        if not Path(args.labels).is_file():
            raise ParameterError(
                f"--labels {args.labels}: no such file (a label CSV: "
                "sequence,start_frame,end_frame,action_label)"
            )
        read_labels(args.labels, args.labels_sequence or stream_id(args.file))
    rec = read_recording(args)
    if args.up:
        rec = dataclasses.replace(rec, skeleton=dataclasses.replace(rec.skeleton, up=args.up))
    stream = args.stream or stream_id(args.file)
    dtype = np.float32 if args.float32 else np.float64
    curve = None
    if args.curve_dir:
        from streamseg.daemon.security import ClientKeys

        curve = ClientKeys.load(args.curve_dir)
    passes = 0

    def waiting():
        print(
            f"streamseg replay: waiting for the daemon at {args.to} (up to {args.wait:g} s)",
            file=sys.stderr,
            flush=True,
        )

    if args.publish is not None:
        return _publish_run(args, rec, stream, dtype, ctx)
    while True:
        try:
            sent = replay(
                rec,
                args.to,
                stream=stream,
                speed=args.speed,
                batch=args.batch,
                dtype=dtype,
                ctx=ctx,
                labels=args.labels,
                labels_sequence=args.labels_sequence
                or (stream_id(args.file) if args.labels else None),
                wait=args.wait,
                on_wait=waiting,
                curve=curve,
            )
        except NoDaemon as err:
            print(f"streamseg replay: {err}", file=sys.stderr)
            return 1
        except KeyboardInterrupt as err:
            if getattr(err, "sent_end", False):
                print(
                    f"streamseg replay: interrupted: sent end of {stream} to {args.to}",
                    file=sys.stderr,
                )
            else:
                print(
                    f"streamseg replay: interrupted: could not send end of {stream} (the "
                    f"daemon at {args.to} took no packet for 1 s); it closes the stream "
                    "when idle",
                    file=sys.stderr,
                )
            return 130
        passes += 1
        print(
            f"streamseg replay: {stream}: sent {sent} frames ({passes} pass"
            f"{'es' if passes > 1 else ''}) to {args.to}",
            flush=True,
        )
        if not args.loop:
            return 0
