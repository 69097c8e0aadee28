"""The README's Python section runs as it stands, and prints what its comments say."""

from __future__ import annotations

import contextlib
import io
import os
import re
from pathlib import Path

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
