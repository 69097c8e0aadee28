"""Command-line subcommands.

Segmentation methods plug into ``streamseg segment`` and ``streamseg eval`` through a module in
this package listed in :data:`METHODS`. Each such module defines:

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

Daemon-side commands (serve, replay, listen) register themselves in :data:`TOOLS` as modules
with ``add_arguments(parser)`` and ``run(args) -> int``.
"""

from __future__ import annotations

METHODS = {
    "lof": "streamseg.commands.lof",
    "aca": "streamseg.commands.aca",
    "rep": "streamseg.commands.rep",
}

TOOLS = {
    "serve": "streamseg.commands.serve",
    "replay": "streamseg.commands.replay",
    "listen": "streamseg.commands.listen",
    "demo": "streamseg.commands.demo",
    "view": "streamseg.commands.view",
    "batch": "streamseg.commands.batch",
    "keys": "streamseg.commands.keys",
}
