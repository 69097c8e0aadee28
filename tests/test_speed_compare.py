"""The speed command's comparison: a figure more than 20 % worse than the recorded run is
flagged (in the direction its unit says), anything else is not. On hand-made asv result
files; the suite's timings themselves are never part of the tests."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

SPEED = Path(__file__).resolve().parents[1] / "benchmarks" / "speed.py"


def _speed():
    spec = importlib.util.spec_from_file_location("speed_command", SPEED)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _result(path: Path, commit: str, date: int, values: dict) -> Path:
    cols = ["result", "params", "version", "started_at", "duration"]
    results = {}
    for name, v in values.items():
        if isinstance(v, dict):  # a parametrized benchmark
            results[name] = [list(v.values()), [list(v)], "x", 0, 0.0]
        else:
            results[name] = [[v], [], "x", 0, 0.0]
    path.write_text(
        json.dumps(
            {"commit_hash": commit, "date": date, "result_columns": cols, "results": results}
        )
    )
    return path


def test_flags_only_figures_more_than_20_percent_worse(tmp_path):
    speed = _speed()
    old = speed.load(
        _result(
            tmp_path / "a.json",
            "aaa",
            1,
            {
                "aca.track_seconds": {"1000": 1.0, "4609": 2.0},
                "daemon.track_rate": 100.0,
                "daemon.track_ok_rate": 100.0,
                "misc.track_mem": 50.0,
            },
        )
    )
    new = speed.load(
        _result(
            tmp_path / "b.json",
            "bbb",
            2,
            {
                "aca.track_seconds": {"1000": 1.19, "4609": 2.5},  # +19 %: fine; +25 %: worse
                "daemon.track_rate": 80.0,  # a rate down 20 % (1 / 0.8 = 1.25 the cost): worse
                "daemon.track_ok_rate": 90.0,  # down 10 %: fine
                "misc.track_mem": 30.0,
            },
        )
    )  # a cost that fell: better, not flagged
    units = {
        "aca.track_seconds": "s",
        "daemon.track_rate": "frames/s",
        "daemon.track_ok_rate": "frames/s",
        "misc.track_mem": "kB",
    }
    rows, worse = speed.compare(new, old, units)
    assert sorted(worse) == [("aca.track_seconds", "4609"), ("daemon.track_rate", "")]
    assert len(rows) == 5
    by_key = {(r[0], r[1]): r for r in rows}
    assert by_key[("misc.track_mem", "")][5] == 30.0 / 50.0
    assert by_key[("aca.track_seconds", "1000")][6] == ""


def test_nothing_recorded_flags_nothing(tmp_path):
    speed = _speed()
    new = speed.load(_result(tmp_path / "b.json", "bbb", 2, {"misc.track_help": 0.1}))
    rows, worse = speed.compare(new, None, {"misc.track_help": "s"})
    assert worse == [] and rows[0][4] is None


def test_without_asv_it_says_how_to_install_it_in_one_line():
    """An interpreter without site-packages (``-S``) has no asv: one line, no traceback."""
    import subprocess
    import sys

    run = subprocess.run(
        [sys.executable, "-I", "-S", str(SPEED), "--bench", "nothing"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 2
    assert "Traceback" not in run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "pip install" in lines[0] and "asv" in lines[0]
