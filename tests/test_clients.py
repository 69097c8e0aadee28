"""``streamseg replay`` / ``listen`` / ``serve`` options / ``demo`` through the real CLI."""

from __future__ import annotations

import json
import subprocess
import sys
import threading

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.client import listen, subscribe
from streamseg.commands import serve
from streamseg.config import DaemonConfig
from streamseg.daemon import Daemon
from streamseg.exceptions import ParameterError
from streamseg.io import read
from streamseg.online.lof import StreamingLOFSegmenter
from tests.cli_words import STREAMSEG, listen_to
from tests.conftest import wait_ready
from tests.motion import lof_input

pytestmark = pytest.mark.daemon
LOOP = "tcp://127.0.0.1:0"


@pytest.fixture
def daemon(warm_kernels):
    d = Daemon(
        DaemonConfig(ingest=LOOP, publish=LOOP, control=LOOP, relabel_interval=0, heartbeat=0)
    )
    ep = d.bind()
    t = threading.Thread(target=d.run, daemon=True)
    t.start()
    wait_ready(d, t)
    yield ep
    d.stop()
    t.join(10)


def files(data_dir):
    return [
        str(data_dir / "cmu86" / "86_01.amc.gz"),
        "--skeleton",
        str(data_dir / "cmu86" / "86.asf"),
    ]


def _replay(daemon, sources, stream, *more) -> int:
    """``streamseg replay SOURCES`` to the daemon as ``stream``, as fast as it takes them."""
    return main(
        ["replay", *sources, "--to", daemon["ingest"], "--speed", "0", "--stream", stream, *more]
    )


def _listener(daemon, *argv):
    """`streamseg listen --control` in its own process; returns it once its first line (the
    late-join state, written after the subscription handshake) is out."""
    proc = subprocess.Popen(
        [
            *STREAMSEG,
            *listen_to(daemon),
            *argv,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    first = proc.stdout.readline()
    assert first, proc.stderr.read()
    return proc, first


def test_replay_then_listen_jsonl_until_end(daemon, data_dir, capsys):
    proc, first = _listener(daemon, "--stream", "x", "--jsonl", "--until-end", "--idle", "30")
    assert json.loads(first) == {"type": "state", "stream": "x", "open": False}
    assert _replay(daemon, files(data_dir), "x", "--batch", "50") == 0
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert capsys.readouterr().out.startswith("streamseg replay: x: sent 4579 frames")
    events = [json.loads(x) for x in out.splitlines()]
    rec = read(data_dir / "cmu86" / "86_01.amc.gz", skeleton=data_dir / "cmu86" / "86.asf")
    seg = StreamingLOFSegmenter(fps=rec.fps)
    feats = lof_input(rec.positions, rec.skeleton, rec.fps)
    want = [c.frame for c in seg.learn_many(feats) + seg.finish()]
    cuts = [e for e in events if e["type"] == "cut"]
    assert [e["frame"] for e in cuts] == want
    # the same as `streamseg segment --online` on the file, latencies included
    assert main(["segment", *files(data_dir), "--online", "--json"]) == 0
    offline = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert offline["cuts"] == [e["frame"] for e in cuts]
    assert offline["cut_latency_frames"] == [e["emitted_at"] - e["frame"] for e in cuts]
    # every event is numbered: 1, 2, 3, ... in publication order, the closed event last
    assert [e["seq"] for e in events] == list(range(1, len(events) + 1))
    assert events[-1] == {
        "type": "closed",
        "stream": "x",
        "reason": "end",
        "frames": 4579,
        "seq": len(events),
    }
    cut = next(e for e in events if e["type"] == "cut")
    assert set(cut) == {
        "type",
        "stream",
        "frame",
        "time",
        "score",
        "emitted_at",
        "provisional",
        "seq",
    }


def test_listen_count_type_and_control_state(daemon, data_dir, capsys):
    closed = subscribe(daemon["publish"], daemon["control"], stream="y", kind="closed")
    _replay(daemon, files(data_dir), "y")
    capsys.readouterr()
    next(listen(closed, timeout=30))  # the daemon has taken the whole first take
    closed.close()
    # the stream is closed: the control endpoint still has its final state
    proc, first = _listener(
        daemon, "--stream", "y", "--type", "cut", "--count", "2", "--idle", "20"
    )
    assert first.startswith("[y] state    frame 4579  revision 0")
    _replay(daemon, files(data_dir), "y")
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    cuts = [x for x in out.splitlines() if "] cut " in x]
    assert len(cuts) == 2


def test_serve_options_toml_then_flags(tmp_path):
    toml = tmp_path / "d.toml"
    toml.write_text("[daemon]\nmax_streams = 7\nrelabel_interval = 2.5\n[aca]\nn_clusters = 3\n")
    parser = __import__("argparse").ArgumentParser()
    serve.add_arguments(parser)
    args = parser.parse_args(["--config", str(toml), "--relabel-interval", "1", "--repetitions"])
    config, algorithms = serve.build(args)
    assert config.max_streams == 7 and config.relabel_interval == 1.0 and config.repetitions
    assert algorithms.aca_config.n_clusters == 3 and algorithms.repetitions
    toml.write_text("[daemon]\nmax_stream = 7\n")
    with pytest.raises(ParameterError, match="unknown DaemonConfig option.*max_stream"):
        serve.build(parser.parse_args(["--config", str(toml)]))
    with pytest.raises(ParameterError, match="max_streams=0 is invalid"):
        DaemonConfig(max_streams=0)


def test_demo_runs_and_draws(tmp_path, capsys):
    png = tmp_path / "t.png"
    assert main(["demo", "--speed", "0", "--plot", str(png), "--http", "127.0.0.1:0"]) == 0
    out = capsys.readouterr().out
    assert "] cut " in out and "] relabel " in out and "closed   (end)" in out
    assert "live page: http://127.0.0.1:" in out  # the test extra has aiohttp
    assert png.stat().st_size > 10_000


def test_minimal_listener_needs_only_pyzmq_and_msgpack(daemon, data_dir):
    """The template client in clients/python/ follows a replay without importing streamseg."""
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "clients" / "python" / "listener.py"
    assert "streamseg" not in "".join(
        line for line in script.read_text().splitlines() if line.startswith(("import", "from"))
    )
    proc = subprocess.Popen(
        [sys.executable, str(script), daemon["publish"], "m", "--control", daemon["control"]],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout.readline().startswith("listening on")  # after its hello handshake
    assert _replay(daemon, files(data_dir), "m", "--batch", "60") == 0
    out, _ = proc.communicate(timeout=60)
    lines = out.splitlines()
    assert lines, "the listener printed nothing"
    rec = read(data_dir / "cmu86" / "86_01.amc.gz", skeleton=data_dir / "cmu86" / "86.asf")
    seg = StreamingLOFSegmenter(fps=rec.fps)
    feats = lof_input(rec.positions, rec.skeleton, rec.fps)
    want = [c.frame for c in seg.learn_many(feats) + seg.finish()]
    got = [int(x.split("cut at frame ")[1].split()[0]) for x in lines if "cut at frame" in x]
    assert got == want
    assert lines[-1] == "m: closed (end)"


def test_replay_and_segment_up_option_fix_a_z_up_file(daemon, data_dir, capsys, tmp_path):
    """A Z-up recording saved without its axis: `--up z` on replay and on segment gives the
    cuts of the Y-up original."""
    import dataclasses

    from streamseg.io.npz import write_npz

    rec = read(data_dir / "cmu86" / "86_01.amc.gz", skeleton=data_dir / "cmu86" / "86.asf")
    x, y, z = (rec.positions[..., i] for i in range(3))
    f = tmp_path / "z_up.npz"
    write_npz(f, dataclasses.replace(rec, positions=np.stack([x, -z, y], axis=-1)))
    assert main(["segment", *files(data_dir), "--online", "--json"]) == 0
    want = json.loads(capsys.readouterr().out.splitlines()[-1])["cuts"]
    assert main(["segment", str(f), "--online", "--json", "--up", "z"]) == 0
    got = capsys.readouterr()
    assert json.loads(got.out.splitlines()[-1])["cuts"] == want and "warning" not in got.err
    # without --up the file's axis (y) is wrong: a warning names the fix, the run goes on
    assert main(["segment", str(f), "--json"]) == 0
    assert "--up z" in capsys.readouterr().err
    s = subscribe(daemon["publish"], daemon["control"], "zf")
    assert _replay(daemon, [str(f)], "zf", "--batch", "60", "--up", "z") == 0
    events = list(listen(s, stream="zf", until_end=True, timeout=30))
    assert [e.frame for e in events if e.type == "cut"] == want
