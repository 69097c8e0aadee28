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

import contextlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from streamseg.cli import main
from streamseg.client import request
from tests.cli_words import FREE_PORTS, STREAMSEG, listen_to

pytestmark = pytest.mark.daemon
ROOT = Path(__file__).resolve().parents[1]
CLIENTS = ROOT / "clients"
N_FRAMES = 2400  # 20 s of 86_01: walk, jump, walk (three cuts)


def _missing(what: str, fix: str):
    if os.environ.get("STREAMSEG_REQUIRE_CLIENTS"):
        pytest.fail(f"{what} is missing: {fix}")
    pytest.skip(f"{what} is missing: {fix}")


@contextlib.contextmanager
def _serve(state_dir, *extra, curve=None):
    """``streamseg serve`` in its own process on free loopback ports, ready (it answers
    ``ping``); its endpoints. Stopped with SIGTERM at the end; it must exit 0."""
    proc = subprocess.Popen(
        [
            *STREAMSEG,
            "serve",
            *FREE_PORTS,
            "--state-dir",
            str(state_dir),
            "--log-level",
            "WARNING",
            *extra,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = proc.stdout.readline()
        assert line.startswith("streamseg serve: ingest="), proc.stderr.read()
        ep = dict(word.split("=", 1) for word in line.split()[2:])
        while True:  # ready once its kernels are warm and the loop runs
            try:
                if request(ep["control"], "ping", timeout=2, curve=curve)["ok"]:
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


@pytest.fixture
def serve(tmp_path):
    with _serve(tmp_path / "state") as ep:
        yield ep


@pytest.fixture
def serve_curve(tmp_path):
    """A daemon with CURVE on every socket (``streamseg keys DIR``, ``--curve-dir DIR``): its
    endpoints, with ``keys`` the folder the clients' ``--keys`` read."""
    from streamseg.daemon.security import ClientKeys

    keys = tmp_path / "keys"
    assert main(["keys", str(keys)]) == 0
    with _serve(
        tmp_path / "state", "--curve-dir", str(keys), curve=ClientKeys.load(str(keys))
    ) as ep:
        yield {**ep, "keys": str(keys)}


@pytest.fixture
def serve_lossy(tmp_path):
    """A daemon whose publish queue holds one message per subscriber (``--hwm 1``): a burst
    of events overflows it, the subscribers see holes in the event numbers."""
    with _serve(
        tmp_path / "state",
        "--hwm",
        "1",
        "--gap-events-per-s",
        "1000000",
        "--heartbeat",
        "0.2",
        "--relabel-interval",
        "0",
    ) as ep:
        yield ep


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
    keys = ["--curve-dir", ep["keys"]] if "keys" in ep else []
    proc = subprocess.Popen(
        [
            *STREAMSEG,
            *listen_to(ep),
            "--stream",
            stream,
            "--jsonl",
            "--until-end",
            "--idle",
            "60",
            *keys,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert json.loads(proc.stdout.readline())["type"] == "state"
    return proc


def _events(proc):
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    return [json.loads(x) for x in out.splitlines()]


def _check_sender(program, ep, take_csv, stream, *more):
    """Run a sender ``program`` (its command words) on the CSV as ``stream``, at full speed
    in packets of 50 frames, ``more`` words after; the daemon's cuts of its stream are the
    CSV's offline cuts."""
    path, cuts = take_csv
    listener = _listen_jsonl(ep, stream)
    cmd = [*program, str(path), "--to", ep["ingest"], "--stream", stream]
    cmd += ["--speed", "0", "--batch", "50", *more]
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
    keys = ["--keys", ep["keys"]] if "keys" in ep else []
    subprocess.run(
        [
            sys.executable,
            str(CLIENTS / "python" / "sender.py"),
            str(path),
            "--to",
            ep["ingest"],
            "--stream",
            stream,
            "--speed",
            "0",
            "--batch",
            "60",
            *keys,
        ],
        check=True,
        timeout=120,
    )
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
        imports = {
            line.split()[1].split(".")[0]
            for line in script.read_text().splitlines()
            if line.startswith(("import ", "from "))
        }
        allowed = {"csv", "math", "os", "statistics", "struct", "sys", "time", "msgpack", "zmq"}
        assert imports <= allowed, (script, imports)


def test_python_sender_streams_a_csv_segmented_as_the_file(serve, take_csv):
    _check_sender(
        [sys.executable, str(CLIENTS / "python" / "sender.py")], serve, take_csv, "py-send"
    )


def test_python_sender_exits_only_once_every_packet_is_out(tmp_path, rec):
    """The whole take (3.4 MB) to a reader slower than the sender: the script ends after its
    queue is delivered, `end` last (before it terminated its own context: 44 of 79)."""
    from tests.test_replay_cli import slow_pull

    path = tmp_path / "whole.csv"
    header = ["time"] + [f"{j}_{a}" for j in rec.skeleton.names for a in "xyz"]
    with path.open("w") as f:
        f.write(",".join(header) + "\n")
        for i, frame in enumerate(rec.positions):
            f.write(f"{i / rec.fps:.6f}," + ",".join(f"{v:.6f}" for v in frame.ravel()) + "\n")
    to, got, reader = slow_pull()
    done = subprocess.run(
        [
            sys.executable,
            str(CLIENTS / "python" / "sender.py"),
            str(path),
            "--to",
            to,
            "--speed",
            "0",
            "--batch",
            "60",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    reader.join()
    assert done.returncode == 0, done.stderr
    assert got == ["announce"] + ["frames"] * -(-rec.n_frames // 60) + ["end"]


def test_python_listener_prints_what_the_daemon_published(serve, take_csv):
    _check_listener(
        [
            sys.executable,
            str(CLIENTS / "python" / "listener.py"),
            serve["publish"],
            "py-listen",
            "--control",
            serve["control"],
        ],
        serve,
        take_csv,
        "py-listen",
    )


# C -----------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def c_clients():
    """``make -C clients/c``: the binaries, built with the distribution's compiler."""
    if shutil.which("cc") is None or shutil.which("make") is None:
        _missing("a C compiler and make", "apt-get install gcc make")
    if not (Path("/usr/include/zmq.h").exists() and Path("/usr/include/msgpack.h").exists()):
        _missing(
            "libzmq and msgpack-c headers", "apt-get install libzmq3-dev libmsgpack-dev pkg-config"
        )
    done = subprocess.run(["make", "-C", str(CLIENTS / "c")], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "warning" not in done.stderr, done.stderr  # -Wall -Wextra -std=c99 -pedantic
    return CLIENTS / "c"


def test_c_sender_streams_a_csv_segmented_as_the_file(serve, take_csv, c_clients):
    _check_sender([str(c_clients / "streamseg-send")], serve, take_csv, "c-send")


def test_c_listener_prints_what_the_daemon_published(serve, take_csv, c_clients):
    _check_listener(
        [
            str(c_clients / "streamseg-listen"),
            serve["publish"],
            "c-listen",
            "--control",
            serve["control"],
        ],
        serve,
        take_csv,
        "c-listen",
    )


def test_c_sender_refuses_a_csv_without_joint_columns(tmp_path, c_clients):
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b\n1,2\n")
    done = subprocess.run(
        [str(c_clients / "streamseg-send"), str(bad)], capture_output=True, text=True, timeout=30
    )
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
    _check_listener(
        [
            "node",
            str(js_client / "listener.js"),
            serve["publish"],
            "js-listen",
            "--control",
            serve["control"],
        ],
        serve,
        take_csv,
        "js-listen",
    )


def test_js_sender_streams_a_csv_segmented_as_the_file(serve, take_csv, js_client):
    _check_sender(["node", str(js_client / "sender.js")], serve, take_csv, "js-send")


def test_every_client_has_a_readme_and_the_protocol_links_them():
    protocol = (ROOT / "docs" / "protocol.md").read_text()
    for lang in ("python", "c", "js"):
        assert (CLIENTS / lang / "README.md").is_file(), lang
        assert f"clients/{lang}/" in protocol, lang


# CURVE and holes, every client ------------------------------------------------------------


def _client(lang, role, c_clients=None, js_client=None):
    """The command of a client program: ``lang`` python, c or js; ``role`` send or listen."""
    if lang == "python":
        return [sys.executable, str(CLIENTS / "python" / f"{role}er.py")]
    if lang == "c":
        return [str(c_clients / f"streamseg-{role}")]
    return ["node", str(js_client / f"{role}er.js")]


@pytest.fixture(params=["python", "c", "js"])
def lang(request):
    """Each client language, with its toolchain checked (a skip, or in CI a failure)."""
    if request.param == "c":
        request.getfixturevalue("c_clients")
    elif request.param == "js":
        request.getfixturevalue("js_client")
    return request.param


def test_clients_speak_curve(lang, serve_curve, take_csv):
    """With ``--keys DIR`` each sender's stream is segmented as the file is and each listener
    prints every cut and the close, on a daemon with CURVE on every socket."""
    ep, c, js = serve_curve, CLIENTS / "c", CLIENTS / "js"
    _check_sender(
        _client(lang, "send", c, js), ep, take_csv, f"{lang}-curve-send", "--keys", ep["keys"]
    )
    _check_listener(
        _client(lang, "listen", c, js)
        + [ep["publish"], f"{lang}-curve-listen", "--control", ep["control"], "--keys", ep["keys"]],
        ep,
        take_csv,
        f"{lang}-curve-listen",
    )


def test_clients_refuse_keys_they_cannot_read(lang, tmp_path):
    c, js = CLIENTS / "c", CLIENTS / "js"
    done = subprocess.run(
        _client(lang, "listen", c, js) + ["tcp://127.0.0.1:1", "--keys", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 2
    assert done.stderr.startswith(f"--keys {tmp_path}: ") and "streamseg keys" in done.stderr


@pytest.mark.parametrize("which", ["python", "c", "js"])
def test_listeners_fill_holes_from_the_event_log(which, serve_lossy, rec, request):
    """A burst of events (every other packet missing: 59 `gap` events at once) overflows a
    publish queue of one message: the Python, C and JavaScript listeners see the holes in the
    event numbers, fetch the missing events with `since` and print every event of the stream once,
    in order, as the log holds them."""
    import zmq

    from streamseg import protocol as P
    from streamseg.client import fetch_since
    from streamseg.commands.replay import announce_of

    tool = (
        None
        if which == "python"
        else request.getfixturevalue("c_clients" if which == "c" else "js_client")
    )
    ep, stream = serve_lossy, f"{which}-holes"
    proc = subprocess.Popen(
        _client(which, "listen", tool, tool) + [ep["publish"], stream, "--control", ep["control"]],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout.readline().startswith("listening on")
    sock = zmq.Context.instance().socket(zmq.PUSH)
    sock.connect(ep["ingest"])
    sock.send_multipart(P.encode(announce_of(rec, stream)))
    for a in range(0, 2400, 20):
        if (a // 20) % 2 == 0:
            sock.send_multipart(P.encode(P.Frames(stream, a, 0.0, rec.positions[a : a + 20])))
    sock.send_multipart(P.encode(P.End(stream)))
    sock.close(linger=10_000)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    logged = fetch_since(ep["control"], stream, 0)
    lines = out.splitlines()
    gaps = [int(x.rsplit(" ", 1)[1]) for x in lines if x.startswith(f"{stream}: gap event ")]
    assert gaps == [e.seq for e in logged if e.type == "gap"] and len(gaps) == 59
    assert len(lines) == len(logged) and lines[-1] == f"{stream}: closed (end)"
    assert "fetched from the event log" in err, "no hole: the burst lost nothing"
