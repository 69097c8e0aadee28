"""``streamseg replay`` without a daemon, and Ctrl-C (SIGINT) mid-stream, as a subprocess."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import threading
import time

import pytest

from streamseg.client import listen, request, subscriber
from streamseg.config import DaemonConfig
from streamseg.daemon import Daemon
from tests.cli_words import STREAMSEG
from tests.waiting import wait_until

pytestmark = pytest.mark.daemon
LOOP = "tcp://127.0.0.1:0"


def replay_cmd(data_dir, to, *extra):
    return [
        *STREAMSEG,
        "replay",
        str(data_dir / "cmu86" / "86_01.amc.gz"),
        "--skeleton",
        str(data_dir / "cmu86" / "86.asf"),
        "--to",
        to,
        *extra,
    ]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_no_daemon_waits_then_gives_up_in_one_line(data_dir):
    proc = subprocess.run(
        replay_cmd(data_dir, f"tcp://127.0.0.1:{free_port()}", "--wait", "1"),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 1
    err = proc.stderr.strip().splitlines()
    assert err[0].startswith("streamseg replay: waiting for the daemon at tcp://127.0.0.1:")
    assert len(err) == 2 and "no daemon took packets" in err[1] and "streamseg serve" in err[1]


def _default_sigint():
    # as from a terminal: an earlier test of the session can leave SIGINT ignored in this
    # process (seen on a fresh clone: the replay then slept through the signal), and an
    # ignored SIGINT is inherited across exec, where Python then installs no handler
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "sigterm"])
def test_ctrl_c_and_sigterm_send_end(data_dir, sig):
    """Ctrl-C, and the SIGTERM of `timeout`, systemd and kill: the daemon gets `end`, not an
    idle stream."""
    d = Daemon(
        DaemonConfig(ingest=LOOP, publish=LOOP, control=LOOP, relabel_interval=0, heartbeat=0)
    )
    ep = d.bind()
    t = threading.Thread(target=d.run, daemon=True)
    t.start()
    assert d.ready.wait(30)
    try:
        s = subscriber(ep["publish"], stream="cc")
        proc = subprocess.Popen(
            replay_cmd(data_dir, ep["ingest"], "--speed", "1", "--stream", "cc"),
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONFAULTHANDLER": "1"},
            preexec_fn=_default_sigint,
        )
        # the stream is open and has taken 2 s of frames: the replay is in its sending loop
        # (past imports and first-use compilation, which are slow on a fresh clone)
        wait_until(
            lambda: (st := request(ep["control"], "streams")["streams"]) and st[0]["frame"] >= 240,
            "the replay's stream took 240 frames",
        )
        proc.send_signal(sig)
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:  # say where it hangs (faulthandler's dump)
            proc.send_signal(signal.SIGABRT)
            proc.wait(10)
            raise AssertionError(
                f"replay still running 30 s after {sig.name}:\n" + proc.stderr.read()[-4000:]
            ) from None
        assert proc.returncode == 130
        assert "interrupted: sent end of cc" in proc.stderr.read()
        closed = [
            e for e in listen(s, stream="cc", until_end=True, timeout=20) if e.type == "closed"
        ]
        assert closed[0].reason == "end" and 0 < closed[0].frames < 4579
    finally:
        d.stop()
        t.join(10)


def slow_pull():
    """A PULL socket on a free loopback port that takes one message per 50 ms with the
    smallest queues, so a fast sender's packets wait in the sender's own queue; the
    messages' types in arrival order (the list grows until the ``end`` message arrives, or
    nothing came for 120 s: a bound, the replay's start may be slow on a fresh clone)."""
    import zmq

    ctx = zmq.Context.instance()
    pull = ctx.socket(zmq.PULL)
    pull.setsockopt(zmq.RCVHWM, 1)
    pull.setsockopt(zmq.RCVBUF, 4096)
    port = pull.bind_to_random_port("tcp://127.0.0.1")
    got = []

    def take():
        while pull.poll(120_000):
            got.append(pull.recv_multipart()[0].split(b"/")[0].decode())
            if got[-1] == "end":
                break
            time.sleep(0.05)  # the input: a consumer slower than the sender
        pull.close()

    reader = threading.Thread(target=take)
    reader.start()
    return f"tcp://127.0.0.1:{port}", got, reader


def test_replay_exits_only_once_every_packet_is_out(data_dir, rec):
    """The process ends after its queue is delivered: pyzmq never terminates its global
    context at exit, so a replay that just closed its socket lost its last ~15 packets and
    its `end` to a daemon slower than the sender (measured before the fix: 26 of 41)."""
    to, got, reader = slow_pull()
    proc = subprocess.run(
        replay_cmd(data_dir, to, "--speed", "0", "--batch", "120"),
        capture_output=True,
        text=True,
        timeout=120,
    )
    reader.join()
    assert proc.returncode == 0, proc.stderr
    n_packets = -(-rec.n_frames // 120)
    assert got == ["announce"] + ["frames"] * n_packets + ["end"]
