"""`serve --http` / `view --http` on an address in use: one line saying so, exit 1, and no
asyncio "Task was destroyed" noise from the half-started page server."""

from __future__ import annotations

import gc
import logging
import socket
import subprocess

import pytest

pytest.importorskip("aiohttp", reason="aiohttp is not installed (pip install -e '.[view]')")

from streamseg.view.server import ViewThread  # noqa: E402
from tests.cli_words import FREE_PORTS, STREAMSEG


@pytest.fixture
def taken():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        yield s.getsockname()[1]


def test_a_view_that_cannot_bind_leaves_no_pending_task(taken, caplog):
    view = ViewThread("tcp://127.0.0.1:9", "tcp://127.0.0.1:9", port=taken)
    with caplog.at_level(logging.ERROR, logger="asyncio"), pytest.raises(OSError):
        view.start()
    view._thread.join(30)
    del view
    gc.collect()  # the tasks of a closed loop are destroyed here, if any were left
    assert not [r for r in caplog.records if "Task was destroyed" in r.getMessage()]


@pytest.mark.daemon
def test_serve_http_on_a_taken_port_is_one_line(taken):
    proc = subprocess.run(
        [
            *STREAMSEG,
            "serve",
            "--http",
            f"127.0.0.1:{taken}",
            *FREE_PORTS,
            "--state-dir",
            "none",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 1
    err = proc.stderr.strip().splitlines()
    assert len(err) == 1, proc.stderr
    assert (
        err[0].startswith(f"streamseg serve: error: cannot serve the page on 127.0.0.1:{taken}")
        and "in use" in err[0]
    )
