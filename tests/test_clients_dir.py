"""The reference clients of ``clients/`` (Python, C, JavaScript) against a real
``streamseg serve`` process on free loopback ports: what they send is segmented as the file
is, what they print is what the daemon published.

The C clients are built with the distribution's compiler (``make -C clients/c``; headers from
Debian's libzmq3-dev and libmsgpack-dev) and the JavaScript one needs ``npm ci`` in
``clients/js``: ``.ci/run`` does both. Where a toolchain is missing these tests skip with the
command that installs it, unless ``STREAMSEG_REQUIRE_CLIENTS=1`` (set by ``.ci/run``) makes
the absence a failure.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from streamseg.cli import main
from streamseg.client import request

pytestmark = pytest.mark.daemon
ROOT = Path(__file__).resolve().parents[1]
CLIENTS = ROOT / "clients"
N_FRAMES = 2400  # 20 s of 86_01: walk, jump, walk (three cuts)


def _missing(what: str, fix: str):
    if os.environ.get("STREAMSEG_REQUIRE_CLIENTS"):
        pytest.fail(f"{what} is missing: {fix}")
    pytest.skip(f"{what} is missing: {fix}")


@pytest.fixture
def serve(tmp_path):
    """``streamseg serve`` in its own process on free loopback ports, ready (it answers
    ``ping``); its endpoints. Stopped with SIGTERM at the end; it must exit 0."""
    loop = "tcp://127.0.0.1:0"
    proc = subprocess.Popen([sys.executable, "-m", "streamseg.cli", "serve", "--ingest", loop,
                             "--publish", loop, "--control", loop, "--state-dir",
                             str(tmp_path / "state"), "--log-level", "WARNING"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert line.startswith("streamseg serve: ingest="), proc.stderr.read()
        ep = dict(word.split("=", 1) for word in line.split()[2:])
        while True:  # ready once its kernels are warm and the loop runs
            try:
                if request(ep["control"], "ping", timeout=2)["ok"]:
                    break
            except TimeoutError:
                assert proc.poll() is None, proc.stderr.read()
        yield ep
    finally:
        proc.terminate()
        try:
            code = proc.wait(30)
        except subprocess.TimeoutExpired:
            proc.kill()
            code = proc.wait()
    err = proc.stderr.read()
    assert code == 0 and "Traceback" not in err, err


@pytest.fixture(scope="module")
def take_csv(tmp_path_factory, data_dir):
    """20 s of CMU 86_01 as the positions CSV the clients send (a time column, then
    ``<joint>_x,_y,_z``), and the cuts ``streamseg segment --online`` finds in that CSV."""
    import contextlib
    import io

    from streamseg.io import read

    rec = read(data_dir / "cmu86" / "86_01.amc.gz", skeleton=data_dir / "cmu86" / "86.asf")
    path = tmp_path_factory.mktemp("take") / "walk.csv"
    header = ["time"] + [f"{j}_{a}" for j in rec.skeleton.names for a in "xyz"]
    with path.open("w") as f:
        f.write(",".join(header) + "\n")
        for i, frame in enumerate(rec.positions[:N_FRAMES]):
            f.write(f"{i / rec.fps:.6f}," + ",".join(f"{v:.6f}" for v in frame.ravel()) + "\n")
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["segment", str(path), "--online", "--json"]) == 0
    cuts = json.loads(out.getvalue().splitlines()[-1])["cuts"]
    assert len(cuts) >= 2, cuts
    return path, cuts


def _listen_jsonl(ep, stream):
    """``streamseg listen --jsonl --until-end`` on ``stream``, subscribed (handshake done)."""
    proc = subprocess.Popen([sys.executable, "-m", "streamseg.cli", "listen", "--from",
                             ep["publish"], "--control", ep["control"], "--stream", stream,
                             "--jsonl", "--until-end", "--idle", "60"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert json.loads(proc.stdout.readline())["type"] == "state"
    return proc


def _events(proc):
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    return [json.loads(x) for x in out.splitlines()]


def _check_sender(cmd, ep, take_csv, stream):
    """Run a sender ``cmd``; the daemon's cuts of its stream are the CSV's offline cuts."""
    path, cuts = take_csv
    listener = _listen_jsonl(ep, stream)
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert f"{stream}: sent {N_FRAMES} frames" in done.stdout, done.stdout
    events = _events(listener)
    assert [e["frame"] for e in events if e["type"] == "cut"] == cuts
    assert events[-1]["type"] == "closed" and events[-1]["frames"] == N_FRAMES
    assert events[-1]["reason"] == "end"


def _check_listener(cmd, ep, take_csv, stream, ready="listening on"):
    """Start a listener ``cmd`` (it prints ``ready`` once subscribed), replay the CSV with
    the Python sender; the listener printed every cut and the close, as the daemon did."""
    path, cuts = take_csv
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = proc.stdout.readline()
    assert first.startswith(ready), first + proc.stderr.read()
    subprocess.run([sys.executable, str(CLIENTS / "python" / "sender.py"), str(path), "--to",
                    ep["ingest"], "--stream", stream, "--speed", "0", "--batch", "60"],
                   check=True, timeout=120)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    lines = out.splitlines()
    got = [int(x.split("cut at frame ")[1].split()[0]) for x in lines if "cut at frame" in x]
    assert got == cuts, out
    relabels = [x for x in lines if x.startswith(f"{stream}: relabel ")]
    assert relabels and f" of 0-{N_FRAMES}: 0-" in relabels[-1], out  # the final one
    assert lines[-1] == f"{stream}: closed (end)", out
    return lines


# Python ------------------------------------------------------------------------------------

def test_python_clients_import_only_pyzmq_and_msgpack():
    for script in (CLIENTS / "python").glob("*.py"):
        imports = {line.split()[1].split(".")[0] for line in script.read_text().splitlines()
                   if line.startswith(("import ", "from "))}
        allowed = {"csv", "math", "os", "statistics", "struct", "sys", "time", "msgpack", "zmq"}
        assert imports <= allowed, (script, imports)


def test_python_sender_streams_a_csv_segmented_as_the_file(serve, take_csv):
    _check_sender([sys.executable, str(CLIENTS / "python" / "sender.py"), str(take_csv[0]),
                   "--to", serve["ingest"], "--stream", "py-send", "--speed", "0",
                   "--batch", "50"], serve, take_csv, "py-send")


def test_python_listener_prints_what_the_daemon_published(serve, take_csv):
    _check_listener([sys.executable, str(CLIENTS / "python" / "listener.py"),
                     serve["publish"], "py-listen", "--control", serve["control"]],
                    serve, take_csv, "py-listen")


# C -----------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def c_clients():
    """``make -C clients/c``: the binaries, built with the distribution's compiler."""
    if shutil.which("cc") is None or shutil.which("make") is None:
        _missing("a C compiler and make", "apt-get install gcc make")
    if not (Path("/usr/include/zmq.h").exists() and Path("/usr/include/msgpack.h").exists()):
        _missing("libzmq and msgpack-c headers",
                 "apt-get install libzmq3-dev libmsgpack-dev pkg-config")
    done = subprocess.run(["make", "-C", str(CLIENTS / "c")], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "warning" not in done.stderr, done.stderr  # -Wall -Wextra -std=c99 -pedantic
    return CLIENTS / "c"


def test_c_sender_streams_a_csv_segmented_as_the_file(serve, take_csv, c_clients):
    _check_sender([str(c_clients / "streamseg-send"), str(take_csv[0]), "--to",
                   serve["ingest"], "--stream", "c-send", "--speed", "0", "--batch", "50"],
                  serve, take_csv, "c-send")


def test_c_listener_prints_what_the_daemon_published(serve, take_csv, c_clients):
    _check_listener([str(c_clients / "streamseg-listen"), serve["publish"], "c-listen",
                     "--control", serve["control"]], serve, take_csv, "c-listen")


def test_c_sender_refuses_a_csv_without_joint_columns(tmp_path, c_clients):
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b\n1,2\n")
    done = subprocess.run([str(c_clients / "streamseg-send"), str(bad)], capture_output=True,
                          text=True, timeout=30)
    assert done.returncode == 2
    assert done.stderr.strip() == f"{bad}: no column is named <joint>_x / _y / _z"


# JavaScript --------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def js_client():
    if shutil.which("node") is None:
        _missing("node", "apt-get install nodejs npm")
    if not (CLIENTS / "js" / "node_modules" / "zeromq").is_dir():
        _missing("clients/js/node_modules", "npm ci --prefix clients/js")
    return CLIENTS / "js"


def test_js_listener_prints_what_the_daemon_published(serve, take_csv, js_client):
    _check_listener(["node", str(js_client / "listener.js"), serve["publish"], "js-listen",
                     "--control", serve["control"]], serve, take_csv, "js-listen")


def test_js_sender_streams_a_csv_segmented_as_the_file(serve, take_csv, js_client):
    _check_sender(["node", str(js_client / "sender.js"), str(take_csv[0]), "--to",
                   serve["ingest"], "--stream", "js-send", "--speed", "0", "--batch", "50"],
                  serve, take_csv, "js-send")


def test_every_client_has_a_readme_and_the_protocol_links_them():
    protocol = (ROOT / "docs" / "protocol.md").read_text()
    for lang in ("python", "c", "js"):
        assert (CLIENTS / lang / "README.md").is_file(), lang
        assert f"clients/{lang}/" in protocol, lang

