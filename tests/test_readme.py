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
