"""Run the live segmentation daemon (ZeroMQ ingest, events, control; see docs/protocol.md).

Options come from the defaults, then ``--config FILE.toml`` (tables ``[daemon]``, ``[lof]``,
``[aca]``), then the command line. SIGINT and SIGTERM shut down cleanly (exit code 0). The
event log and checkpoints go to ``--state-dir`` (default ``$XDG_STATE_HOME/streamseg``;
``none``: off).
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import signal

from streamseg.config import DaemonConfig


def field_help(cls) -> dict:
    """Field name -> its description, from the numpydoc ``Attributes`` section of ``cls``
    (one source for the docstring, ``--help`` and the TOML keys)."""
    lines = (cls.__doc__ or "").split("Attributes\n    ----------\n", 1)[-1].splitlines()
    out, names = {}, []
    for line in lines:
        if line.startswith("    ") and not line.startswith("        ") and " : " in line:
            names = [n.strip() for n in line.split(" : ")[0].split(",")]
        elif line.startswith("        ") and names:
            for n in names:
                out[n] = (out.get(n, "") + " " + line.strip()).strip()
    return out


def _plain(text: str) -> str:
    """Docstring markup out of a help text (``x`` -> x, :mod:`a.b` -> a.b)."""
    import re

    text = re.sub(r":\w+:`~?([^`]+)`", r"\1", text)
    return text.replace("``", "")


def add_arguments(parser) -> None:
    parser.add_argument(
        "--config", metavar="FILE.toml", help="TOML file with tables [daemon], [lof], [aca]"
    )
    parser.add_argument(
        "--log-level", default="INFO", choices=["DEBUG", "INFO", "WARNING", "ERROR"]
    )
    parser.add_argument(
        "--http",
        metavar="HOST:PORT",
        help="also serve the live web page (streamseg view) at this address, "
        "e.g. 127.0.0.1:8765 (needs the view extra)",
    )
    from streamseg.commands.lsl import add_lsl_source_arguments

    lsl = parser.add_argument_group("Lab Streaming Layer (needs the lsl extra)")
    lsl.add_argument(
        "--lsl-markers",
        action="store_true",
        help="publish cut, segments, rep and closed events as an LSL marker "
        "stream (type Markers), stamped with the LSL time of their frame",
    )
    add_lsl_source_arguments(lsl, prefix="lsl-")
    described = field_help(DaemonConfig)
    said: dict = {}  # a paragraph shared by several options is printed once, at the first
    for f in dataclasses.fields(DaemonConfig):
        kind = type(f.default)
        para = _plain(described.get(f.name, ""))
        if para in said:
            para = f"see --{said[para].replace('_', '-')}"
        else:
            said[para] = f.name
        # the library's "" (no state) is not serve's default: the paragraph says serve's
        default = "" if f.name == "state_dir" else f" (default {f.default!r})"
        text = f"{para}{default}".strip().replace("%", "%%")
        if kind is bool:
            parser.add_argument(
                "--" + f.name.replace("_", "-"),
                dest=f.name,
                default=None,
                action=argparse.BooleanOptionalAction,
                help=text,
            )
            continue
        if kind is tuple:  # a list: the option is repeated
            parser.add_argument(
                "--" + f.name.replace("_", "-"),
                dest=f.name,
                default=None,
                action="append",
                metavar="ENDPOINT",
                help=f"{para} (repeatable)".replace("%", "%%"),
            )
            continue
        parser.add_argument(
            "--" + f.name.replace("_", "-"),
            dest=f.name,
            default=None,
            type=kind,
            metavar={"state_dir": "DIR", "markers": "MAP.toml"}.get(f.name, kind.__name__.upper()),
            help=text,
        )


def build(args):
    """``(DaemonConfig, Algorithms)`` from parsed arguments."""
    from streamseg.daemon import load_config
    from streamseg.daemon.algorithms import Algorithms

    config, lof, aca, rep = DaemonConfig(), None, None, None
    if args.config:
        config, lof, aca, rep = load_config(args.config)
    overrides = {
        f.name: getattr(args, f.name)
        for f in dataclasses.fields(DaemonConfig)
        if getattr(args, f.name, None) is not None
    }
    if "subscribe" in overrides:  # given on the command line too: both lists
        overrides["subscribe"] = (*config.subscribe, *overrides["subscribe"])
    config = dataclasses.replace(config, **overrides)
    if not config.state_dir:  # the library default is none; a service keeps its log
        from streamseg.daemon.state_files import default_state_dir

        config = dataclasses.replace(config, state_dir=str(default_state_dir()))
    elif config.state_dir == "none":
        config = dataclasses.replace(config, state_dir="")
    return config, Algorithms(lof, aca, repetitions=config.repetitions, rep_config=rep)


def _check_before_binding(args, config) -> None:
    """Options that would fail after the sockets are bound and the address printed, refused
    first with one line that says how to fix them."""
    from pathlib import Path

    from streamseg.exceptions import ParameterError

    if getattr(args, "http", None):
        from streamseg.commands.view import http_address

        http_address(args.http)
    if config.state_dir:
        path = Path(config.state_dir).expanduser()
        existing = next((p for p in (path, *path.parents) if p.exists()), None)
        if existing is not None and not existing.is_dir():
            raise ParameterError(
                f"--state-dir {config.state_dir}: {existing} is a file, not a "
                "folder: give a folder for the event log and checkpoints "
                "(created if missing), or none"
            )


def run(args) -> int:
    from streamseg.daemon import Daemon

    logging.basicConfig(
        level=args.log_level, format="%(asctime)s %(name)s %(levelname)s %(message)s"
    )
    config, algorithms = build(args)
    _check_before_binding(args, config)
    view_keys = None
    if getattr(args, "http", None) and config.curve_dir:
        from streamseg.daemon.security import ClientKeys

        # the page is one more client of the daemon: with CURVE on it needs a client key
        view_keys = ClientKeys.load(config.curve_dir)
    daemon = Daemon(config, algorithms)
    endpoints = daemon.bind()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: daemon.stop())
    print("streamseg serve: " + " ".join(f"{k}={v}" for k, v in endpoints.items()), flush=True)
    lsl = _start_lsl(args, daemon, endpoints, view_keys or _client_keys(config))
    view = None
    if getattr(args, "http", None):
        from streamseg.commands.view import start_view

        view = start_view(
            endpoints["publish"], endpoints.get("control"), args.http, curve=view_keys
        )
        print(f"streamseg serve: live view {view.url}", flush=True)
    try:
        return daemon.run()
    finally:
        if view is not None:
            view.stop()
        for part in lsl:
            part.stop()


def _client_keys(config):
    if not config.curve_dir:
        return None
    from streamseg.daemon.security import ClientKeys

    return ClientKeys.load(config.curve_dir)


def _start_lsl(args, daemon, endpoints: dict, curve) -> list:
    """The LSL inlet bridge (``--lsl-type/--lsl-name/--lsl-source-id``) and the marker outlet
    (``--lsl-markers``), each a client of the daemon in this process."""
    parts = []
    if args.lsl_markers:
        from streamseg.lsl.markers import MarkerOutlet

        def time_of(stream, frame):
            st = daemon.streams.get(stream)
            return None if st is None or st.t0 is None else st.time_of(frame)

        parts.append(
            MarkerOutlet(endpoints["publish"], endpoints["control"], time_of, curve=curve).start()
        )
        print("streamseg serve: LSL marker stream 'streamseg' (type Markers)", flush=True)
    if args.lsl_type or args.lsl_name or args.lsl_source_id:
        from streamseg.lsl.bridge import Bridge

        def say(line):
            print(f"streamseg serve: {line}", flush=True)

        parts.append(
            Bridge(
                endpoints["ingest"],
                args.lsl_type,
                args.lsl_name,
                args.lsl_source_id,
                args.lsl_up,
                curve=curve,
                on_error=lambda m: say(f"error: {m}"),
                on_open=say,
                markers=daemon.algorithms.markers,
            ).start()
        )
    return parts
