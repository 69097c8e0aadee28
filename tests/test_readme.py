"""The README's Python section runs as it stands, and prints what its comments say."""

from __future__ import annotations

import contextlib
import io
import os
import re
from pathlib import Path

import pytest

from tests.cli_words import FREE_PORTS, STREAMSEG
from tests.waiting import wait_until

ROOT = Path(__file__).resolve().parents[1]


def test_python_api_example_runs():
    text = (ROOT / "README.md").read_text()
    section = text.split("## Python API", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert blocks, "the README lost its Python example"
    out = io.StringIO()
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        with contextlib.redirect_stdout(out):
            for code in blocks:
                exec(compile(code, "README.md", "exec"), {})
    finally:
        os.chdir(cwd)
    lines = out.getvalue().splitlines()
    assert lines[0] == "[ 589 1141 2001 2502 3276 4066]"
    assert lines[1].startswith("CutEvent(frame=589, score=") and "emitted_at=809" in lines[1]
    assert lines[2].startswith("4 [Segment(start=0, end=536, label=3), ")
    assert lines[3].startswith("4 [Segment(start=0, end=145, label=0), ")  # four squats


def _command_lines(text):
    """Every ``streamseg ...`` line of the README's bash blocks, continuations joined, comments
    and a trailing ``&`` dropped."""
    lines = []
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split(" #", 1)[0].strip().rstrip("&").strip()
            if line.startswith("streamseg "):
                lines.append(line)
    return lines


def test_every_command_line_parses_and_its_files_exist():
    import shlex

    from streamseg.cli import build_parser

    lines = _command_lines((ROOT / "README.md").read_text())
    assert len(lines) >= 10, lines
    parser = build_parser()
    for line in lines:
        words = shlex.split(line)[1:]
        err = io.StringIO()
        try:
            with contextlib.redirect_stderr(err):
                parser.parse_args(words)
        except SystemExit:
            raise AssertionError(f"README: {line!r} does not parse: {err.getvalue()}") from None
        for w in words:
            if w.startswith("data/"):
                assert (ROOT / w).exists(), f"README: {line!r} names a missing file {w}"


# What the README's commands need that a test cannot give them as written: files of the
# user's own (placeholders), a Dask scheduler on another host, a Lab Streaming Layer source.
PLACEHOLDERS = ("take.bvh", "take.amc", "features.npy", "takes/", "--lsl-type")
SERVICE = ("streamseg serve", "streamseg replay", "streamseg listen")


def _lines(kind):
    lines = _command_lines((ROOT / "README.md").read_text())
    if kind == "placeholder":
        return [x for x in lines if any(p in x for p in PLACEHOLDERS)]
    rest = [x for x in lines if not any(p in x for p in PLACEHOLDERS)]
    if kind == "service":
        return [x for x in rest if x.startswith(SERVICE)]
    return [x for x in rest if not x.startswith(SERVICE)]


def _run(words, cwd=ROOT, **kw):
    import subprocess
    import sys

    return subprocess.run(
        [sys.executable, "-m", "streamseg.cli", *words],
        cwd=cwd,
        capture_output=True,
        text=True,
        **kw,
    )


def test_the_commands_left_out_are_only_those_needing_the_users_own_things():
    left = _lines("placeholder")
    assert len(left) == 6, left  # four `segment take...`, batch on a remote scheduler, LSL
    assert len(_lines("file")) == 6 and len(_lines("service")) == 5


@pytest.mark.slow
@pytest.mark.parametrize("line", _lines("file"))
def test_a_file_command_of_the_readme_runs_as_written_on_data(line, tmp_path):
    """Each command on ``data/``, run from the repository root as the README gives it (only
    what it writes goes to a temporary folder): exit 0, no error line."""
    import shlex

    words = shlex.split(line)[1:]
    for i, w in enumerate(words):
        if w.startswith("/tmp/") or (i and words[i - 1] in ("--output", "-o", "--plot")):
            words[i] = str(tmp_path / Path(w).name)
    done = _run(words, timeout=600)
    assert done.returncode == 0, f"README: {line!r}: {done.stderr[-2000:]}"
    assert "error" not in done.stderr.lower().replace("errors", ""), done.stderr[-2000:]
    assert done.stdout.strip(), line


def _serve(line, tmp_path, name):
    """The README's ``streamseg serve ...`` on free loopback ports (the defaults may be taken
    on a shared machine) with a state folder of its own; ``(process, endpoints, url)``."""
    import shlex
    import subprocess

    words = shlex.split(line)[1:]
    words = [("127.0.0.1:0" if w.startswith("127.0.0.1:") else w) for w in words]
    proc = subprocess.Popen(
        [
            *STREAMSEG,
            *words,
            *FREE_PORTS,
            "--state-dir",
            str(tmp_path / name),
            "--log-level",
            "WARNING",
        ],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    first = proc.stdout.readline()
    assert first.startswith("streamseg serve: ingest="), proc.stderr.read()
    ep = dict(w.split("=", 1) for w in first.split()[2:])
    url = None
    if "--http" in words:
        url = proc.stdout.readline().split("live view ", 1)[1].strip()
    from streamseg.client import request

    while True:  # ready once its kernels are warm
        try:
            if request(ep["control"], "ping", timeout=2)["ok"]:
                return proc, ep, url
        except TimeoutError:
            assert proc.poll() is None, proc.stderr.read()


def _on(line, ep):
    """A README line with the default endpoints replaced by the daemon's."""
    import shlex

    ports = {"5560": ep["ingest"], "5561": ep["publish"], "5562": ep["control"]}
    return [
        next((v for k, v in ports.items() if w == f"tcp://127.0.0.1:{k}"), w)
        for w in shlex.split(line)[1:]
    ]


def _stop(proc):
    proc.terminate()
    try:
        assert proc.wait(60) == 0, proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()


@pytest.mark.slow
@pytest.mark.daemon
def test_the_live_service_commands_run_as_written(tmp_path):
    """serve, replay (at 4x, as written) and listen --until-end: the listener prints the
    cuts and relabels of 86_01 and ends at its close."""
    import subprocess
    import sys

    serve, replay, listen = _lines("service")[:3]
    assert serve.startswith("streamseg serve") and "replay" in replay and "listen" in listen
    proc, ep, _ = _serve(serve, tmp_path, "state")
    try:
        follower = subprocess.Popen(
            [sys.executable, "-m", "streamseg.cli", *_on(listen, ep)],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert follower.stdout.readline().startswith("[*] streams")  # subscribed
        done = _run(_on(replay, ep), timeout=300)
        assert done.returncode == 0, done.stderr
        assert done.stdout.startswith("streamseg replay: 86_01: sent 4579 frames")
        out, err = follower.communicate(timeout=300)
        assert follower.returncode == 0, err
        assert "[86_01] cut      frame     589" in out and "] relabel " in out
        assert out.splitlines()[-1].startswith("[86_01] closed   (end) after 4579 frames")
    finally:
        _stop(proc)


@pytest.mark.slow
@pytest.mark.daemon
def test_the_live_view_commands_run_as_written(tmp_path):
    """serve --http and the replay with --labels: the page lists the stream with its human
    labels."""
    import json
    import urllib.request

    pytest.importorskip("aiohttp")
    serve, replay = _lines("service")[3:5]
    assert "--http" in serve and "--labels" in replay
    proc, ep, url = _serve(serve, tmp_path, "state")
    try:
        done = _run(_on(replay, ep), timeout=600)
        assert done.returncode == 0, done.stderr
        rows = wait_until(
            lambda: (
                (rows := json.load(urllib.request.urlopen(url + "api/streams"))["rows"])
                and rows[0].get("closed")
                and rows
            ),
            "the view listed the replayed stream as closed",
        )
        assert rows[0]["stream"] == "86_01" and rows[0]["closed"] == "end"
    finally:
        _stop(proc)
