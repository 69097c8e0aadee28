"""A full disk under the state directory: a real, small tmpfs (mounted in a user and mount
namespace of the daemon's own, so nothing is left mounted), filled by a file."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

from benchmarks.faults._machine import can_mount, fill
from streamseg import protocol as P
from streamseg.client import fetch_since, request, subscriber
from tests.test_daemon_restart import Sender, config, wait_ping
from tests.waiting import wait_until

pytestmark = pytest.mark.daemon
SIZE_MB = 40


def serve_on_tmpfs(toml, state):
    """The daemon in its own mount namespace, ``state`` a tmpfs of SIZE_MB there; the test
    reaches the files through /proc/PID/root."""
    state.mkdir(exist_ok=True)
    proc = subprocess.Popen(
        [
            "unshare",
            "-rm",
            "sh",
            "-c",
            'mount -t tmpfs -o size="$1"m tmpfs "$2" && exec "$3" '
            '-m streamseg.cli serve --config "$4" --log-level WARNING',
            "sh",
            str(SIZE_MB),
            str(state),
            sys.executable,
            str(toml),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout.readline().startswith("streamseg serve: ingest="), proc.stderr.read()
    return proc


def test_a_full_disk_keeps_the_log_whole_and_pauses_checkpoints(tmp_path, rec):
    """The disk fills up while a stream runs: every event seen live is still logged (the
    log's reserve), checkpoint rounds pause and say so; once space is freed they resume and
    their WAL stays truncated."""
    if not can_mount():
        pytest.skip("no tmpfs in a user namespace here (unshare -rm and mount refused)")
    ep, state, toml = config(
        tmp_path, relabel_interval=1.0, relabel_history=8.0, heartbeat=0.2, checkpoint_interval=0.1
    )
    proc = serve_on_tmpfs(toml, state)
    sub = subscriber(ep["publish"])
    sender = Sender(ep, rec)
    try:
        wait_ping(ep, proc)
        root = f"/proc/{proc.pid}/root{state}"
        sender.start()
        wait_until(
            lambda: request(ep["control"], "stats")["totals"].get("checkpoints_written"),
            "a checkpoint written",
        )
        filler = f"{root}/fill"
        fill(filler)
        assert shutil.disk_usage(root).free < 1 << 20
        seen, paused = [], False
        while len([e for e in seen if e.stream == "k"]) < 40 or not paused:
            assert sub.poll(60_000), "no event from the daemon"
            ev = P.decode(sub.recv_multipart())
            if getattr(ev, "seq", None) is not None:
                seen.append(ev)
                paused = paused or (ev.type == "error" and ev.reason == "checkpoint")
        logged = {}
        for key in {e.stream or P.DAEMON_WIDE for e in seen}:
            logged.update({(key, e.seq): e for e in fetch_since(ep["control"], key, 0)})
        missing = [e for e in seen if logged.get((e.stream or P.DAEMON_WIDE, e.seq)) != e]
        assert missing == []
        totals = request(ep["control"], "stats")["totals"]
        assert "event_log" not in totals["errors_by_reason"]
        # space again: the rounds resume, the checkpoints' WAL is emptied after each
        os.remove(filler)
        written = totals["checkpoints_written"]
        wait_until(
            lambda: request(ep["control"], "stats")["totals"]["checkpoints_written"] >= written + 5,
            "five checkpoint rounds after the space came back",
        )
        wal = f"{root}/checkpoints.sqlite-wal"
        assert os.path.getsize(wal) < 1 << 20
    finally:
        sender.stopping.set()
        sub.close(linger=0)
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
