"""streamseg: live motion-capture segmentation (cuts, action labels, repetitions).

Commands: info, segment, eval, batch (files); serve, replay, listen, view, keys, demo (the
daemon). Output of segment/eval --json: docs/output.md. Exit codes: 0 ok, 1 runtime
failure, 2 usage.
"""

# Start-up is part of the interface: only the chosen command's module is imported (its
# options are defined there, streamseg.commands.COMMANDS lists them), so `streamseg --help`
# loads no numpy, numba or ZeroMQ.

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import sys

from streamseg.commands import COMMANDS
from streamseg.exceptions import ParameterError, RecordingError, SkeletonError, StreamsegError


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line (what is wrong, where the help is), exit code 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class _Formatter(argparse.RawDescriptionHelpFormatter):
    """Help with the default of every option that has one and does not already say it."""

    def _get_help_string(self, action):
        text = action.help or ""
        if (
            "default" not in text
            and action.default not in (None, False, argparse.SUPPRESS)
            and action.option_strings
            and not isinstance(action.default, bool)
        ):
            text += " (default: %(default)s)"
        return text


def _plain(text: str) -> str:
    """A docstring as help text: no Sphinx/RST markup."""
    return text.replace("``", "").replace(":func:", "").replace(":mod:", "").replace("`", "")


def build_parser(commands=None) -> argparse.ArgumentParser:
    """The parser, with the options of the subcommands named in ``commands`` (their modules
    are the only ones imported); None: every subcommand's (for documentation and tests)."""
    parser = _Parser(prog="streamseg", description=__doc__, formatter_class=_Formatter)
    sub = parser.add_subparsers(dest="command", required=True)
    for name, (module_name, helptext) in COMMANDS.items():
        p = sub.add_parser(name, help=helptext, description=helptext, formatter_class=_Formatter)
        if commands is None or name in commands:
            module = importlib.import_module(module_name)
            if module.__doc__:
                p.description = _plain(module.__doc__.strip())
            module.add_arguments(p)
            p.set_defaults(run=module.run)
    return parser


def _chosen(argv) -> str | None:
    """The subcommand named in ``argv`` (the first word that is not an option), if any."""
    word = next((a for a in argv if not a.startswith("-")), None)
    return word if word in COMMANDS else None


def _failure(args, err: BaseException) -> int:
    """One line on stderr for a failure, and its exit code: 2 when what was asked cannot be
    done as asked (an option, an input file that is missing or unreadable), 1 when it failed
    while running (sockets, the daemon, an internal error)."""
    where = f"streamseg {getattr(args, 'command', '')}".rstrip()
    if isinstance(err, (ParameterError, SkeletonError, RecordingError)):
        print(f"{where}: error: {err}", file=sys.stderr)
        return 2
    if isinstance(err, (FileNotFoundError, IsADirectoryError, PermissionError)):
        print(f"{where}: error: {err.strerror}: {err.filename}", file=sys.stderr)
        return 2
    zmq = sys.modules.get("zmq")  # only a command that imported it can fail with its errors
    if zmq is not None and isinstance(err, zmq.ZMQError):
        hint = (
            "another process uses the port: choose other ports (e.g. tcp://127.0.0.1:0 "
            "for a free one) or stop that process"
            if err.errno == zmq.EADDRINUSE
            else "endpoints look like tcp://127.0.0.1:5560"
            if err.errno == zmq.EINVAL
            else "check the endpoints and that the daemon runs"
        )
        print(f"{where}: error: {err.strerror}: {hint}", file=sys.stderr)
        return 2 if err.errno == zmq.EINVAL else 1  # a malformed endpoint is a usage error
    if isinstance(err, (StreamsegError, OSError)):
        print(f"{where}: error: {err}", file=sys.stderr)
        return 1
    print(
        f"{where}: internal error: {type(err).__name__}: {err} (please report it; "
        "STREAMSEG_DEBUG=1 shows the traceback)",
        file=sys.stderr,
    )
    return 1


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    command = _chosen(argv)
    parser = build_parser([command] if command else [])
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        # the reader went away (`streamseg info x | head`): not an error; stop quietly
        with contextlib.suppress(OSError):
            sys.stdout = open(os.devnull, "w")  # noqa: SIM115 (flushed at exit)
        return 0
    except Exception as err:
        if os.environ.get("STREAMSEG_DEBUG"):
            raise
        return _failure(args, err)


if __name__ == "__main__":
    sys.exit(main())
