"""Serve a live web page of a daemon's streams (cuts, relabelled actions, health).

The page is at the printed address (loopback by default: it has no authentication). Needs
the ``view`` extra: ``pip install 'streamseg[view]'``.
"""

from __future__ import annotations

from streamseg.exceptions import ParameterError, StreamsegError

DEFAULT_HTTP = "127.0.0.1:8765"


def add_arguments(parser) -> None:
    parser.add_argument(
        "--from", dest="source", required=True, metavar="ENDPOINT", help="daemon publish endpoint"
    )
    parser.add_argument(
        "--control",
        metavar="ENDPOINT",
        help="daemon control endpoint: history of streams already running, "
        "rates and buffer fill (recommended)",
    )
    parser.add_argument(
        "--http",
        default=DEFAULT_HTTP,
        metavar="HOST:PORT",
        help=f"address of the page (default {DEFAULT_HTTP}; port 0: any free)",
    )
    parser.add_argument(
        "--interval",
        type=float,
        default=0.1,
        metavar="S",
        help="seconds between coalesced page updates (default 0.1)",
    )
    parser.add_argument(
        "--no-labels",
        dest="labels",
        action="store_false",
        help="do not read the human label files replays announce",
    )
    parser.add_argument(
        "--curve-dir",
        metavar="DIR",
        help="CURVE keys made by `streamseg keys DIR` (client.key_secret, "
        "server.key), for a daemon served with --curve-dir",
    )


def http_address(text: str) -> tuple[str, int]:
    """``(host, port)`` of ``HOST:PORT``, ``:PORT`` or ``PORT`` (host 127.0.0.1)."""
    host, _, port = text.rpartition(":")
    host = host.strip("[]") or "127.0.0.1"
    try:
        number = int(port)
        if not 0 <= number < 65536:
            raise ValueError
    except ValueError:
        raise ParameterError(
            f"--http {text!r}: expected HOST:PORT with a port in 0..65535, e.g. {DEFAULT_HTTP}"
        ) from None
    return host, number


def start_view(publish: str, control: str | None, http: str, **kwargs):
    """Start a :class:`~streamseg.view.ViewThread`; a missing extra or a busy port is a
    :class:`StreamsegError` (one line for the command line)."""
    host, port = http_address(http)
    try:
        from streamseg.view.server import ViewThread
    except ImportError as err:
        raise StreamsegError(
            f"the view needs aiohttp ({err.name} is missing): pip install 'streamseg[view]'"
        ) from None
    view = ViewThread(publish, control, host=host, port=port, **kwargs)
    try:
        view.start()
    except OSError as err:
        raise StreamsegError(
            f"cannot serve the page on {host}:{port}: {err.strerror or err}; "
            "pick another --http address (port 0: any free port)"
        ) from None
    from streamseg.view.server import _loopback

    if not _loopback(host):
        print(
            f"streamseg view: warning: serving on {host}, not loopback; the page has no "
            "authentication",
            flush=True,
        )
    return view


def run(args) -> int:
    import signal
    import threading

    done = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):  # before the address: a script may stop us
        signal.signal(sig, lambda *_: done.set())
    if not args.interval > 0:  # before the signal handlers: Ctrl-C still works on an error
        raise ParameterError(
            f"--interval {args.interval:g} is invalid: expected seconds "
            "> 0 between page updates (default 0.1)"
        )
    curve = None
    if args.curve_dir:
        from streamseg.daemon.security import ClientKeys

        curve = ClientKeys.load(args.curve_dir)
    view = start_view(
        args.source,
        args.control,
        args.http,
        interval=args.interval,
        labels=args.labels,
        curve=curve,
    )
    print(f"streamseg view: {view.url}  (events from {args.source})", flush=True)
    done.wait()
    view.stop()
    return 0
