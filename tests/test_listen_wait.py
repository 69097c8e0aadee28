"""`streamseg listen` at an endpoint where no daemon runs says it is waiting and gives up
after --timeout (default: replay's --wait), one line each, exit 1; never waits silently."""

from __future__ import annotations

import socket
import subprocess
import sys

from streamseg.cli import build_parser


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_listen_without_a_daemon_says_so_and_gives_up():
    endpoint = f"tcp://127.0.0.1:{_free_port()}"
    proc = subprocess.run(
        [sys.executable, "-m", "streamseg.cli", "listen", "--from", endpoint, "--timeout", "1.5"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 1
    assert proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 2, proc.stderr
    assert lines[0] == (
        f"streamseg listen: waiting for a daemon at {endpoint} (giving up after 1.5 s)"
    )
    assert lines[1].startswith(f"streamseg listen: no daemon at {endpoint} for 1.5 s")
    assert "Traceback" not in proc.stderr


def test_listen_waits_as_long_as_replay_by_default():
    parser = build_parser()
    listen = parser.parse_args(["listen", "--from", "tcp://127.0.0.1:5561"])
    replay = parser.parse_args(["replay", "x.amc", "--to", "tcp://127.0.0.1:5560"])
    assert listen.timeout == replay.wait == 10.0
