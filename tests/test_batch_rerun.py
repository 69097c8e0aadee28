"""`streamseg batch` into a file that already holds results: other options are refused in one
line (not skipped and reported as if new), and a retried recording's line replaces its old
error line (one line per recording)."""

from __future__ import annotations

import json
import shutil

import pytest

from streamseg.cli import main

pytest.importorskip("distributed", reason="batch needs the dask extra")


@pytest.fixture
def clips(tmp_path, data_dir):
    src = data_dir / "hdm05_reps"
    a = next((src / "squat1Reps").glob("HDM_bd_*.amc.gz"))
    b = next((src / "hopBothLegs1hops").glob("HDM_bd_*.amc.gz"))
    d = tmp_path / "takes"
    d.mkdir()
    for f in (a, b):
        shutil.copy(f, d / f.name)
    shutil.copy(src / "asf" / "HDM_bd.asf", d / "HDM_bd.asf")
    return d, sorted(str(p) for p in d.glob("*.amc.gz"))


def _lines(path):
    return [json.loads(x) for x in path.read_text().splitlines()]


def test_rerun_with_other_options_is_refused(tmp_path, capsys, clips):
    _, files = clips
    out = tmp_path / "o.jsonl"
    assert main(["batch", *files, "--method", "lof", "--workers", "1", "--output", str(out)]) == 0
    assert all(o["batch_options"]["method"] == "lof" for o in _lines(out))
    capsys.readouterr()
    before = out.read_text()
    assert main(["batch", *files, "--method", "aca", "--workers", "1", "--output", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "made with other options" in err[0], err
    assert "--method 'lof' (now 'aca')" in err[0]
    assert out.read_text() == before  # nothing written
    # a LOF option changed is as much another result as another method
    assert (
        main(
            [
                "batch",
                *files,
                "--method",
                "lof",
                "--delay",
                "2",
                "--workers",
                "1",
                "--output",
                str(out),
            ]
        )
        == 2
    )
    assert "--delay default (now 2.0)" in capsys.readouterr().err
    # the same options resume it: nothing to run
    assert main(["batch", *files, "--method", "lof", "--workers", "1", "--output", str(out)]) == 0
    assert "already in" in capsys.readouterr().err


def test_retried_recording_replaces_its_error_line(tmp_path, capsys, clips):
    folder, files = clips
    good = files[1]
    saved = tmp_path / "saved.amc.gz"
    shutil.move(good, saved)
    with open(good, "wb") as fh:
        fh.write(b"not a recording")
    out = tmp_path / "o.jsonl"
    assert main(["batch", *files, "--workers", "1", "--output", str(out)]) == 0  # skipped
    assert sum("error" in o and o["skipped"] for o in _lines(out)) == 1
    shutil.move(saved, good)  # the recording is repaired
    assert main(["batch", *files, "--retry-failed", "--workers", "1", "--output", str(out)]) == 0
    capsys.readouterr()
    lines = _lines(out)
    assert sorted(o["file"] for o in lines) == files  # one line per recording
    assert not any("error" in o for o in lines)
