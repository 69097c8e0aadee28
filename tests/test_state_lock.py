"""One daemon per state directory: a second one refuses it, before touching its files.

(The lock going with its process on kill -9 is test_daemon_restart's restart on the same
directory.)
"""

from __future__ import annotations

import dataclasses
import sqlite3
import threading

import pytest

from streamseg.cli import main
from streamseg.client import request, subscribe
from streamseg.commands.replay import replay
from streamseg.config import DaemonConfig
from streamseg.daemon import Daemon
from streamseg.daemon.state_lock import StateDirInUse
from tests.waiting import wait_until

pytestmark = pytest.mark.daemon
LOOP = "tcp://127.0.0.1:0"


def test_a_second_daemon_on_the_same_state_dir_is_refused(start_daemon, rec, tmp_path, capsys):
    state = tmp_path / "state"
    d, ep = start_daemon(state_dir=str(state), checkpoint_interval=0.05)
    s = subscribe(ep["publish"], ep["control"], stream="held")
    # a stream left open (no end): the first daemon holds its checkpoint
    replay(
        dataclasses.replace(rec, positions=rec.positions[:600]),
        ep["ingest"],
        stream="held",
        speed=0,
        batch=20,
        end=False,
    )
    wait_until(
        lambda: request(ep["control"], "state", stream="held").get("frame") == 600,
        "the daemon took the 600 frames",
        timeout=30,
    )
    assert request(ep["control"], "checkpoint")["streams"] == 1
    s.close()
    logged = (
        sqlite3.connect(state / "events.sqlite")
        .execute("SELECT COUNT(*) FROM events")
        .fetchone()[0]
    )

    with pytest.raises(StateDirInUse, match="in use by another daemon"):
        Daemon(DaemonConfig(ingest=LOOP, publish=LOOP, control=LOOP, state_dir=str(state)))
    # the command line: one line that says what to do, usage exit code, no traceback
    assert (
        main(
            [
                "serve",
                "--state-dir",
                str(state),
                "--ingest",
                LOOP,
                "--publish",
                LOOP,
                "--control",
                LOOP,
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "in use by another daemon" in err[0] and "--state-dir" in err[0]

    # the refused ones restored nothing, closed nothing, logged nothing
    assert [st["stream"] for st in request(ep["control"], "streams")["streams"]] == ["held"]
    con = sqlite3.connect(state / "checkpoints.sqlite")
    assert [r[0] for r in con.execute("SELECT stream FROM checkpoints")] == ["held"]
    assert (
        sqlite3.connect(state / "events.sqlite")
        .execute("SELECT COUNT(*) FROM events")
        .fetchone()[0]
        == logged
    )

    # once the first daemon has stopped, the directory is free again
    d.stop()
    for t in threading.enumerate():
        if t.name == "streamseg-daemon-under-test":
            t.join(30)
    d2, _ = start_daemon(state_dir=str(state))
    assert d2.state_lock is not None
