"""Feed Lab Streaming Layer motion-capture streams to a daemon (``pip install streamseg[lsl]``).

``streamseg lsl --to tcp://127.0.0.1:5560 [--type MoCap] [--name NAME] [--source-id ID]``
resolves the matching LSL streams and sends each to the daemon as a stream (its id: the
LSL source id, else its name), announced from the stream's channel description (the XDF
mocap meta-data: per coordinate a channel with label, marker and type PositionX/Y/Z) and
stamped with LSL time. Streams that come and go are followed until Ctrl-C or SIGTERM, which
end every stream. The daemon itself can do this (``serve --lsl-type MoCap``) and publish its
events back to LSL (``serve --lsl-markers``). liblsl's own settings (discovery scope,
session) come from the file ``LSLAPICFG`` names.
"""

from __future__ import annotations

import sys


def add_lsl_source_arguments(parser, prefix: str = "") -> None:
    """--type/--name/--source-id/--up (``prefix``: ``lsl-`` in serve)."""
    from streamseg.recording import UP_AXES

    p = f"--{prefix}"
    parser.add_argument(
        f"{p}type",
        dest="lsl_type",
        metavar="TYPE",
        default=None if prefix else "MoCap",
        help="LSL stream type to resolve" + ("" if prefix else " (default MoCap)"),
    )
    parser.add_argument(
        f"{p}name", dest="lsl_name", metavar="NAME", help="only the LSL streams of this name"
    )
    parser.add_argument(
        f"{p}source-id",
        dest="lsl_source_id",
        metavar="ID",
        help="only the LSL stream of this source id",
    )
    parser.add_argument(
        f"{p}up",
        dest="lsl_up",
        choices=UP_AXES,
        help="world up axis of the streams' positions (default: the axis the "
        "body stands along in the first second, else y)",
    )


def add_arguments(parser) -> None:
    from streamseg.commands.args import endpoint

    parser.add_argument(
        "--to", required=True, type=endpoint, metavar="ENDPOINT", help="daemon ingest endpoint"
    )
    add_lsl_source_arguments(parser)
    parser.add_argument(
        "--stream",
        metavar="ID",
        help="daemon stream id (one LSL stream only; default: its source id, else its name)",
    )
    parser.add_argument(
        "--curve-dir",
        metavar="DIR",
        help="CURVE keys made by `streamseg keys DIR` (client.key_secret, server.key)",
    )
    parser.add_argument(
        "--markers",
        metavar="MAP.toml",
        help="a marker set of your own for streams whose channels are markers "
        "no skeleton names: TOML of joint = marker or [markers] "
        "(docs/guide/formats.md); sent as the joints it makes",
    )


def _say(line: str) -> None:
    print(f"streamseg lsl: {line}", flush=True)


def run(args) -> int:
    import signal
    import threading

    from streamseg.lsl.bridge import Bridge, predicate

    markers = None
    if args.markers:  # a bad map is said before any stream is resolved
        from streamseg.skeleton.marker_map import load_marker_map

        markers = load_marker_map(args.markers)
    curve = None
    if args.curve_dir:
        from streamseg.daemon.security import ClientKeys

        curve = ClientKeys.load(args.curve_dir)
    bridge = Bridge(
        args.to,
        args.lsl_type,
        args.lsl_name,
        args.lsl_source_id,
        args.lsl_up,
        args.stream,
        curve,
        on_error=lambda m: print(f"streamseg lsl: error: {m}", file=sys.stderr, flush=True),
        on_open=_say,
        markers=markers,
    )
    done = threading.Event()
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: done.set())
    bridge.start()
    query = predicate(args.lsl_type, args.lsl_name, args.lsl_source_id)
    _say(f"waiting for LSL streams ({query}); Ctrl-C ends them")
    try:
        while not done.wait(0.5):
            pass
    finally:
        bridge.stop()
        _say(f"stopped ({sum(f.frames_sent for f in bridge.feeders.values())} frames sent)")
    return 0
