"""A Dask cluster of separate processes (``dask scheduler``, ``dask worker``) on loopback.

The daemon relabels through it while a worker is killed mid-job (the scheduler retries the
job on the other worker), a small ``batch`` runs through it, and then the scheduler itself is
killed mid-job (the daemon runs the job locally and says so with an ``error`` event).
Readiness is waited for through the client (connect, ``wait_for_workers``), never by sleeping.
"""

from __future__ import annotations

import functools
import json
import os
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest

distributed = pytest.importorskip("distributed")

from streamseg.cli import main  # noqa: E402
from streamseg.client import listen, subscriber  # noqa: E402
from streamseg.commands.replay import replay  # noqa: E402
from streamseg.config import DaemonConfig  # noqa: E402
from streamseg.daemon import Daemon  # noqa: E402
from streamseg.daemon.algorithms import Algorithms  # noqa: E402
from streamseg.io import read  # noqa: E402
from streamseg.online.lof import StreamingLOFSegmenter  # noqa: E402
from tests import dask_gate  # noqa: E402
from tests.motion import lof_input  # noqa: E402

pytestmark = [pytest.mark.daemon, pytest.mark.slow]
ROOT = Path(__file__).resolve().parents[1]
LOOP = "tcp://127.0.0.1:0"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def dask_cli(*args, log) -> subprocess.Popen:
    exe = Path(sys.executable).with_name("dask")
    env = dict(os.environ, PYTHONPATH=str(ROOT))  # workers import tests.dask_gate
    return subprocess.Popen(
        [str(exe), *args], stdout=log, stderr=subprocess.STDOUT, env=env, cwd=ROOT
    )


@pytest.fixture
def cluster(tmp_path):
    """``(address, client, scheduler process, worker processes)``: 2 single-thread workers."""
    address = f"tcp://127.0.0.1:{free_port()}"
    log = open(tmp_path / "dask.log", "w")
    procs = [
        dask_cli(
            "scheduler",
            "--host",
            "127.0.0.1",
            "--port",
            address.rsplit(":", 1)[1],
            "--dashboard-address",
            "127.0.0.1:0",
            log=log,
        )
    ]
    for i in range(2):
        procs.append(
            dask_cli(
                "worker",
                address,
                "--nthreads",
                "1",
                "--nworkers",
                "1",
                "--host",
                "127.0.0.1",
                "--dashboard-address",
                "127.0.0.1:0",
                "--name",
                f"w{i}",
                "--no-nanny",
                log=log,
            )
        )
    client = distributed.Client(address, timeout=60, set_as_default=False)  # waits for it
    client.wait_for_workers(2, timeout=120)
    yield address, client, procs[0], procs[1:]
    client.close()
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    for p in procs:
        try:
            p.wait(30)
        except subprocess.TimeoutExpired:
            p.kill()
    log.close()


def test_relabels_and_batch_through_separate_processes(cluster, tmp_path, data_dir, capsys):
    address, client, scheduler, workers = cluster
    rec = read(data_dir / "cmu86" / "86_01.amc.gz", skeleton=data_dir / "cmu86" / "86.asf")
    take = rec.slice(0, 1800)  # 15 s: its final relabel window is gated
    gate = tmp_path / "gate"
    gate.mkdir()
    algorithms = Algorithms(relabel=functools.partial(dask_gate.gated_relabel, str(gate)))
    d = Daemon(
        DaemonConfig(
            ingest=LOOP,
            publish=LOOP,
            control=LOOP,
            heartbeat=0.2,
            relabel_interval=1000.0,
            relabel_history=60.0,
            # one relabel per take, the final one: no relabels that settle
            # provisional cuts (docs/protocol.md, Settled cuts)
            settle=0.0,
            relabel_backend="dask",
            relabel_scheduler=address,
        ),
        algorithms,
    )
    ep = d.bind()
    t = threading.Thread(target=d.run, daemon=True)
    t.start()
    try:
        # both workers warm: a job never waits behind a warm-up (the gated job holds one)
        assert d.ready.wait(60) and d.worker.wait_warm(180)
        s = subscriber(ep["publish"])
        next(e for e in listen(s, timeout=30) if e.type == "stats")  # subscribed

        # 1. a worker killed mid-job: the scheduler runs the job again on another worker
        pid_of = client.run(os.getpid)  # worker address -> pid
        replay(take, ep["ingest"], stream="k", speed=0, batch=60)  # ends: the final relabel
        first = dask_gate.wait_started(gate, 1)[0]
        assert first in pid_of.values()
        # while that job is stuck on the cluster, another stream is cut and closed as usual
        short = rec.slice(0, 900)  # its final window is too short to be gated
        seg = StreamingLOFSegmenter(fps=rec.fps)
        want = [
            c.frame
            for c in seg.learn_many(lof_input(short.positions, short.skeleton, short.fps))
            + seg.finish()
        ]
        replay(short, ep["ingest"], stream="c", speed=0, batch=60)
        other = [
            e
            for e in listen(s, stream="c", until_end=True, timeout=120)
            if getattr(e, "stream", None) == "c"
        ]  # the subscriber has every stream's events
        assert [e.frame for e in other if e.type == "cut" and e.provisional] == want and want
        assert not (gate / "release").exists() and dask_gate.started(gate) == [first]
        os.kill(first, signal.SIGKILL)
        second = dask_gate.wait_started(gate, 2)[1]
        assert second != first and second in pid_of.values()
        (gate / "release").touch()
        events = [
            e
            for e in listen(s, stream="k", until_end=True, timeout=120)
            if getattr(e, "stream", None) == "k"
        ]
        segs = [e for e in events if e.type == "segments"]
        assert [e.revision for e in segs] == [1] and segs[0].final
        assert (segs[0].start, segs[0].end) == (0, take.n_frames)
        assert not [e for e in events if e.type == "error"]
        assert d.worker.fallbacks == 0  # retried by the cluster, not here

        # 2. a small batch through the same (now one-worker) cluster
        out = tmp_path / "batch.jsonl"
        files = [str(data_dir / "cmu02" / f"02_0{i}.amc.gz") for i in (3, 5)]
        rc = main(["batch", *files, "--scheduler", address, "--output", str(out)])
        capsys.readouterr()
        lines = [json.loads(x) for x in out.read_text().splitlines()]
        assert rc == 0 and sorted(o["file"] for o in lines) == files
        assert all(o["method"] == "lof" and "cuts" in o for o in lines)

        # 3. the scheduler killed mid-job: the job runs in the daemon, with an error event
        (gate / "release").unlink()
        for f in gate.glob("started-*"):
            f.unlink()
        replay(take, ep["ingest"], stream="x", speed=0, batch=60)
        dask_gate.wait_started(gate, 1)
        scheduler.kill()
        scheduler.wait(30)
        told = next(
            e for e in listen(s, timeout=120) if e.type == "error" and e.reason == "relabel_backend"
        )
        assert "runs locally" in told.message
        assert os.getpid() in dask_gate.wait_started(gate, 2)  # the local fallback runs it
        (gate / "release").touch()
        events = [
            e
            for e in listen(s, stream="x", until_end=True, timeout=120)
            if getattr(e, "stream", None) == "x"
        ]
        segs = [e for e in events if e.type == "segments"]
        assert [e.revision for e in segs] == [1] and segs[0].final
        assert segs[0].end == take.n_frames and d.worker.fallbacks >= 1
    finally:
        d.stop()
        t.join(60)
    assert not t.is_alive()
