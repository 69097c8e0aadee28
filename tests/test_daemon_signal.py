"""``streamseg serve`` as a subprocess: SIGTERM mid-stream exits 0 after final events."""

from __future__ import annotations

import signal

import pytest
import zmq

from streamseg import protocol as P
from streamseg.client import listen, request, subscribe
from streamseg.commands.replay import announce_of
from streamseg.io import read
from tests.test_daemon_restart import serve, wait_ping
from tests.waiting import wait_until

pytestmark = pytest.mark.daemon


@pytest.mark.slow
def test_sigterm_mid_stream_publishes_final_events(tmp_path, data_dir):
    rec = read(data_dir / "cmu86" / "86_01.amc.gz", skeleton=data_dir / "cmu86" / "86.asf")
    ep = {k: f"ipc://{tmp_path}/{k}" for k in ("ingest", "publish", "control")}
    toml = tmp_path / "d.toml"
    toml.write_text(
        f'[daemon]\ningest = "{ep["ingest"]}"\npublish = "{ep["publish"]}"\n'
        f'control = "{ep["control"]}"\nrelabel_interval = 2.0\n'
        "relabel_history = 8.0\nheartbeat = 0.5\n"
    )
    proc = serve(toml)
    try:
        wait_ping(ep, proc)
        s = subscribe(ep["publish"], ep["control"], stream="t")
        push = zmq.Context.instance().socket(zmq.PUSH)
        push.setsockopt(zmq.LINGER, 2000)
        push.connect(ep["ingest"])
        push.send_multipart(P.encode(announce_of(rec, "t")))
        n = 3000  # mid-stream: no end message
        for a in range(0, n, 30):
            push.send_multipart(P.encode(P.Frames("t", a, 0.0, rec.positions[a : a + 30])))
        push.close()
        wait_until(
            lambda: request(ep["control"], "state", stream="t").get("frame", -1) >= n,
            f"the daemon took the {n} frames",
        )
        proc.send_signal(signal.SIGTERM)
        events = list(listen(s, stream="t", until_end=True, timeout=20))
        assert proc.wait(20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert events[-1] == P.Closed("t", "shutdown", n)
    final = [e for e in events if e.type == "segments" and e.final]
    assert len(final) == 1 and final[0].end == n
    assert "Traceback" not in proc.stderr.read()
