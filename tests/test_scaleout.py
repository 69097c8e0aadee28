"""Scale-out on a real Dask cluster: the daemon's dask relabel backend and ``streamseg batch``.

An in-process LocalCluster (threads, for speed) serves the daemon; ``batch`` runs on its
default local cluster of worker processes. Separate ``dask scheduler`` / ``dask worker``
processes, killed mid-job: tests/test_scaleout_processes.py.
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading

import pytest

distributed = pytest.importorskip("distributed")

from streamseg.cli import main  # noqa: E402
from streamseg.client import listen, subscriber  # noqa: E402
from streamseg.commands import batch_tasks as batch  # noqa: E402
from streamseg.commands.replay import replay  # noqa: E402
from streamseg.config import DaemonConfig  # noqa: E402
from streamseg.daemon import Daemon  # noqa: E402
from streamseg.daemon.algorithms import Algorithms  # noqa: E402
from streamseg.daemon.pipeline import StreamPipeline  # noqa: E402
from streamseg.daemon.relabel_job import relabel  # noqa: E402
from streamseg.scaleout import local_cluster  # noqa: E402

LOOP = "tcp://127.0.0.1:0"


@pytest.fixture(scope="module")
def threads_cluster():
    cluster = local_cluster(2, processes=False)
    yield cluster
    cluster.close()


def start(config: dict, algorithms=None):
    """A daemon on random loopback ports, running in a thread; returns (daemon, endpoints,
    subscriber) once a heartbeat shows the subscription is live."""
    cfg = dict(ingest=LOOP, publish=LOOP, control=LOOP, heartbeat=0.2)
    cfg.update(config)
    d = Daemon(DaemonConfig(**cfg), algorithms)
    ep = d.bind()
    t = threading.Thread(target=d.run, daemon=True, name="streamseg-daemon-under-test")
    t.start()
    assert d.ready.wait(60)
    s = subscriber(ep["publish"])
    next(e for e in listen(s, timeout=30) if e.type == "stats")  # subscribed
    d._thread = t
    return d, ep, s


def stop(d):
    d.stop()
    d._thread.join(30)
    assert not d._thread.is_alive()


def same_partition(a, b) -> bool:
    """Two segmentations with the same boundaries and the same grouping (ids aside)."""
    if [(s, e) for s, e, _ in a] != [(s, e) for s, e, _ in b]:
        return False
    pairs = {(x[2], y[2]) for x, y in zip(a, b)}
    return len(pairs) == len({p[0] for p in pairs}) == len({p[1] for p in pairs})


def test_relabels_on_an_in_process_cluster_equal_local_ones(threads_cluster, rec):
    d, ep, s = start(
        dict(
            relabel_interval=5.0,
            relabel_history=10.0,
            relabel_backend="dask",
            relabel_scheduler=threads_cluster.scheduler_address,
        )
    )
    try:
        assert d.worker.wait_connected(60)
        replay(rec, ep["ingest"], stream="dk", speed=0, batch=60)
        events = list(listen(s, stream="dk", until_end=True, timeout=120))
    finally:
        stop(d)
    segs = [e for e in events if e.type == "segments"]
    assert [e.revision for e in segs] == list(range(1, len(segs) + 1))
    assert segs[-1].final and segs[-1].end == rec.n_frames and events[-1].type == "closed"
    assert not [e for e in events if e.type == "error"]
    assert d.worker.sent == d.worker.returned >= 1 and d.worker.fallbacks == 0
    # the final revision is the local computation of the same window (ids aside)
    p = StreamPipeline(rec.skeleton, rec.fps, Algorithms(), history=10.0)
    p.push(rec.positions, 0)
    p.finish()
    feats, frames = p.snapshot()
    local = relabel(Algorithms(), feats, frames, rec.fps, None, tuple(p.cut_frames))
    assert (segs[-1].start, segs[-1].end) == (local.start, local.end)
    assert same_partition(segs[-1].segments, local.segments)


def test_many_streams_come_back_in_revision_order(threads_cluster, rec):
    """Four streams, their jobs out at once, three rounds: each round sends 3 s more of every
    stream and waits for each stream's next revision (a handshake); ids and order hold."""
    import zmq

    from streamseg import protocol as P
    from streamseg.commands.replay import announce_of

    d, ep, s = start(
        dict(
            relabel_interval=2.0,
            relabel_history=6.0,
            relabel_backend="dask",
            relabel_scheduler=threads_cluster.scheduler_address,
        )
    )
    names = [f"m{i}" for i in range(4)]
    sock = zmq.Context.instance().socket(zmq.PUSH)
    sock.setsockopt(zmq.LINGER, 5000)
    sock.connect(ep["ingest"])
    events, chunk = [], 360
    try:
        assert d.worker.wait_connected(60)
        for n in names:
            sock.send_multipart(P.encode(announce_of(rec, n)))
        for r in range(3):
            for n in names:
                a = r * chunk
                sock.send_multipart(
                    P.encode(P.Frames(n, a, a / rec.fps, rec.positions[a : a + chunk]))
                )
            waiting = set(names)
            for e in listen(s, timeout=120):
                events.append(e)
                if e.type == "segments" and e.revision == r + 1:
                    waiting.discard(e.stream)
                    if not waiting:
                        break
            assert not waiting, f"round {r}: no revision from {waiting}"
        for n in names:
            sock.send_multipart(P.encode(P.End(n)))
        closed = set()
        for e in listen(s, timeout=120):
            events.append(e)
            closed |= {e.stream} if e.type == "closed" else set()
            if closed >= set(names):
                break
    finally:
        sock.close()
        stop(d)
    for n in names:
        segs = [e for e in events if e.type == "segments" and e.stream == n]
        assert [e.revision for e in segs] == [1, 2, 3, 4] and segs[-1].final, n
        assert segs[-1].end == 3 * chunk
    assert d.worker.fallbacks == 0 and d.worker.sent == d.worker.returned == 16


def run_blocked(*argv) -> subprocess.CompletedProcess:
    """``streamseg ARGV`` in a Python where ``import dask`` / ``distributed`` fails."""
    code = (
        "import sys; sys.modules['distributed'] = None; sys.modules['dask'] = None; "
        "from streamseg.cli import main; sys.exit(main(sys.argv[1:]))"
    )
    return subprocess.run(
        [sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=120
    )


def test_without_dask_the_daemon_works_and_the_dask_backend_says_what_to_install(tmp_path):
    r = run_blocked(
        "serve", "--relabel-backend", "dask", "--ingest", LOOP, "--publish", LOOP, "--control", LOOP
    )
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "pip install streamseg[dask]" in r.stderr
    r = run_blocked("batch", "data/cmu86", "--output", str(tmp_path / "o.jsonl"))
    assert r.returncode == 2 and "pip install streamseg[dask]" in r.stderr
    assert r.stderr.strip().count("\n") == 0
    code = (
        "import sys; sys.modules['distributed'] = None; "
        "from streamseg.config import DaemonConfig; from streamseg.daemon import Daemon; "
        "L = 'tcp://127.0.0.1:0'; d = Daemon(DaemonConfig(ingest=L, publish=L, control=L)); "
        "d.bind(); print(type(d.worker).__name__); d.ctx.destroy(linger=0)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "RelabelWorker", out.stderr


def segment_json(capsys, *argv) -> dict:
    assert main(["segment", *argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_batch_on_local_worker_processes(tmp_path, capsys, data_dir):
    """The default local cluster (worker processes): one line per recording, each the
    ``segment --json`` object plus "file"; a bad one is its own error line; a rerun skips."""
    bad = tmp_path / "broken.amc"
    bad.write_text("not an amc\n")
    files = [
        str(data_dir / "cmu86" / "86_01.amc.gz"),
        str(data_dir / "cmu02" / "02_05.amc.gz"),
        str(bad),
    ]
    out = tmp_path / "lines.jsonl"
    rc = main(
        [
            "batch",
            *files,
            "--method",
            "lof",
            "--workers",
            "2",
            "--output",
            str(out),
            "--labels",
            str(data_dir),
        ]
    )
    printed = capsys.readouterr()
    assert rc == 0  # one skipped with its reason; the others segmented
    lines = [json.loads(x) for x in out.read_text().splitlines()]
    assert sorted(o["file"] for o in lines) == sorted(files)
    by = {o["file"]: o for o in lines}
    assert set(by[str(bad)]) == {"file", "error", "skipped", "batch_options"}
    assert str(bad) in by[str(bad)]["error"]
    for f in files[:2]:
        want = segment_json(capsys, f, "--skeleton", batch.skeleton_for(f))
        got = {k: v for k, v in by[f].items() if k not in ("seconds", "scores", "batch_options")}
        assert got == want
    # --labels: the scores of `eval --all` (its LOF offline row) for the labelled 86_01
    from streamseg.evaluation.corpus import STREAMSEG_METHODS, discover, evaluate_all, json_row

    items = [i for i in discover(data_dir / "cmu86") if i.name == "86_01"]
    rows, _ = evaluate_all(items, {"LOF offline": STREAMSEG_METHODS["LOF offline"]}, runs=1)
    want = json_row(rows[0][2])  # under the JSON key names, as eval --all --json writes them
    got = by[files[0]]["scores"]
    for k in ("precision", "recall", "f1", "f1_1s", "covering", "n_cuts"):
        assert got[k] == pytest.approx(want[k]), k
    assert "summary" not in printed.out and "| 86_01 |" in printed.out  # the scores table
    assert "SKIPPED broken.amc" in printed.err  # the progress bar names it
    assert "3 recordings (3 run now, 0 already in " in printed.out
    assert "2 segmented; 1 skipped" in printed.out and "0 failed; 1 scored against" in printed.out
    # a rerun runs nothing; --retry-failed runs the skipped one again (and it fails again)
    rc = main(["batch", *files, "--output", str(out)])
    assert rc == 0 and len(out.read_text().splitlines()) == 3
    assert "already in" in capsys.readouterr().err
    rc = main(
        [
            "batch",
            *files,
            "--method",
            "lof",
            "--output",
            str(out),
            "--retry-failed",
            "--workers",
            "1",
        ]
    )
    assert rc == 0 and len(out.read_text().splitlines()) == 3  # its line replaced
    assert "2 already in" in capsys.readouterr().err


def test_batch_expands_folders_and_globs_and_finds_each_skeleton(data_dir):
    got = batch.expand([str(data_dir / "cmu86"), str(data_dir / "cmu02" / "02_0[12]*")])
    assert got[0].endswith("86_01.amc.gz") and len(got) == 3
    assert batch.skeleton_for(got[0]).endswith("86.asf")
    assert batch.skeleton_for(got[1]).endswith("02.asf")
    hdm = batch.expand([str(data_dir / "hdm05_reps")])
    assert all(batch.skeleton_for(f) is not None for f in hdm)
    f = next(f for f in hdm if "HDM_dg_" in f)
    assert batch.skeleton_for(f).endswith("HDM_dg.asf")


def test_batch_output_is_strict_json_and_a_cut_line_is_skipped(tmp_path, capsys, data_dir):
    out = tmp_path / "o.jsonl"
    f = str(data_dir / "cmu02" / "02_03.amc.gz")
    out.write_text('{"file": "elsewhere.amc", "error": "x"}\n{"file": "' + f + '", "n_fr')
    rc = main(["batch", f, "--method", "aca", "--workers", "1", "--output", str(out)])
    capsys.readouterr()
    assert rc == 0
    lines = out.read_text().splitlines()
    assert len(lines) == 3  # the cut-short line stays on its own line, ignored
    obj = json.loads(lines[-1], parse_constant=lambda c: pytest.fail(f"non-strict {c}"))
    assert obj["file"] == f and obj["method"] == "haca"


def test_backend_option_picks_the_worker_and_rejects_unknown_names():
    from streamseg.daemon.backends import relabel_worker
    from streamseg.daemon.dask_worker import DaskRelabelWorker
    from streamseg.daemon.worker import RelabelWorker
    from streamseg.exceptions import ParameterError

    with pytest.raises(ParameterError, match="relabel_backend"):
        DaemonConfig(relabel_backend="cluster")
    with pytest.raises(ParameterError, match="relabel_scheduler"):
        DaemonConfig(relabel_scheduler="localhost")
    w = relabel_worker(Algorithms(), DaemonConfig(relabel_backend="process"))
    assert isinstance(w, RelabelWorker) and w.pool is not None
    w.stop()
    w = relabel_worker(Algorithms(), DaemonConfig())
    assert isinstance(w, RelabelWorker) and w.pool is None
    w = relabel_worker(
        Algorithms(), DaemonConfig(relabel_backend="dask", relabel_scheduler="tcp://127.0.0.1:1")
    )
    assert isinstance(w, DaskRelabelWorker)


def test_an_unreachable_scheduler_means_local_relabels_and_an_error_event(rec):
    import socket

    with socket.socket() as sk:  # a port nobody listens on
        sk.bind(("127.0.0.1", 0))
        port = sk.getsockname()[1]
    d, ep, s = start(
        dict(
            relabel_interval=5.0,
            relabel_history=10.0,
            relabel_backend="dask",
            relabel_scheduler=f"tcp://127.0.0.1:{port}",
        )
    )
    try:
        replay(rec.slice(0, 1500), ep["ingest"], stream="u", speed=0, batch=60)
        events, closed, told = [], False, False
        for e in listen(s, timeout=120):  # the stream closes; the failed connection is told
            events.append(e)
            closed |= e.type == "closed" and e.stream == "u"
            told |= e.type == "error" and e.reason == "relabel_backend"
            if closed and told:
                break
    finally:
        stop(d)
    assert closed
    told = [e for e in events if e.type == "error" and e.reason == "relabel_backend"]
    assert told and "not reachable" in told[0].message
    segs = [e for e in events if e.type == "segments" and e.stream == "u"]
    assert segs and segs[-1].final and segs[-1].end == 1500
    assert d.worker.sent == 0 and d.worker.fallbacks >= 1


def test_batch_says_in_one_line_what_is_wrong(tmp_path, capsys, data_dir):
    assert (
        main(["batch", str(data_dir / "cmu86"), "--output", str(tmp_path / "missing" / "o.jsonl")])
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "not a file in an existing folder" in err
    assert (
        main(
            [
                "batch",
                str(tmp_path / "empty*.amc"),
                "--output",
                str(tmp_path / "o.jsonl"),
                "--labels",
                str(tmp_path),
            ]
        )
        == 2
    )
    assert "no recordings" in capsys.readouterr().err
    assert (
        main(
            [
                "batch",
                str(data_dir / "cmu86"),
                "--output",
                str(tmp_path / "o.jsonl"),
                "--labels",
                str(tmp_path),
            ]
        )
        == 2
    )
    assert "no label CSV" in capsys.readouterr().err
