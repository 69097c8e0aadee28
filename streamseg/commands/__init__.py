"""Command-line subcommands, one module each, imported only when that command runs.

:data:`COMMANDS` is the whole table ``streamseg --help`` is built from: name -> (module, one
help line). Each command module defines

``add_arguments(parser)``
    Add the command's options to its argparse parser. **New flags go here**, in the
    command's own module, never in ``streamseg/cli.py``.
``run(args) -> int``
    Run it; raise :class:`streamseg.exceptions.StreamsegError` subclasses for failures the
    user can fix (the CLI prints them as one line).

Keep a command module's top-level imports light (argparse, the standard library,
:mod:`streamseg.commands.args`, :mod:`streamseg.config`): the parser of the chosen command is
built before it runs, and ``tests/test_cli_startup.py`` checks that ``streamseg --help``
imports neither numpy nor any command module. A command module never imports
``streamseg.cli``.

Segmentation methods plug into ``streamseg segment`` and ``streamseg eval`` through a module
listed in :data:`METHODS`. Each such module defines:

``add_arguments(group)``
    Add the method's own options to an argparse argument group. Option names must not clash
    with the common ones (FILE, --skeleton, --method, --json, --plot, --labels, --sequence,
    --fps) or with another method's.
``segment(args) -> dict``
    Run the method on ``args.file`` and return the JSON-able result (``n_frames``, ``fps``,
    ``method``, ... as the method's issue specifies). Writes ``args.plot`` when given.
``evaluate(args) -> dict``
    Score the method against ``args.labels``; returns a flat mapping of measure to value
    (nested ``confusion`` allowed), which the CLI prints.
"""

from __future__ import annotations

#: name -> (module, help line), in the order ``streamseg --help`` lists them
COMMANDS = {
    "info": (
        "streamseg.commands.info",
        "summarize a recording (or feature matrix) and its features",
    ),
    "segment": ("streamseg.commands.segment", "segment a recording offline (or --online)"),
    "eval": ("streamseg.commands.evaluate", "score a segmentation against human labels"),
    "serve": (
        "streamseg.commands.serve",
        "run the live segmentation daemon (ZeroMQ ingest, events, control)",
    ),
    "replay": (
        "streamseg.commands.replay",
        "replay a recording as a live stream to a daemon's ingest endpoint",
    ),
    "listen": ("streamseg.commands.listen", "subscribe to a daemon's events and print them"),
    "demo": (
        "streamseg.commands.demo",
        "live demo: daemon + replay of CMU 86_01 + listener, then a timeline picture",
    ),
    "view": (
        "streamseg.commands.view",
        "serve a live web page of a daemon's streams (cuts, actions, health)",
    ),
    "batch": (
        "streamseg.commands.batch",
        "segment or evaluate a whole corpus on a Dask cluster (JSON lines)",
    ),
    "keys": ("streamseg.commands.keys", "generate CURVE key pairs for the daemon and its clients"),
    "lsl": (
        "streamseg.commands.lsl",
        "feed Lab Streaming Layer mocap streams to a daemon (LSL time, reconnecting)",
    ),
}

METHODS = {
    "lof": "streamseg.commands.lof",
    "aca": "streamseg.commands.aca",
    "rep": "streamseg.commands.rep",
}
