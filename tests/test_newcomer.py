"""What a newcomer trips on (issue 44's table): each gets one line saying what is wrong and
how to fix it (exit 2), never an ``internal error``, a ``MemoryError`` or silence."""

from __future__ import annotations

import numpy as np
import pytest

from tests.test_cli_audit import _one_line
from tests.waiting import wait_until


@pytest.fixture(scope="module")
def features(tmp_path_factory):
    f = tmp_path_factory.mktemp("x") / "X.npy"
    np.save(f, np.random.default_rng(0).normal(size=(600, 19)).astype("f4"))
    return f


@pytest.mark.parametrize(
    "argv, said",
    [
        (["--fps", "1e9"], "at most 10000"),
        (["--fps", "120", "--buffer", "1e9"], "lower buffer_s (--buffer)"),
        (["--fps", "120", "--k", "100000000"], "k (--k)"),
        (["--fps", "120", "--delay", "1e12"], "delay_s (--delay)"),
        (["--fps", "120", "--refine", "1e9"], "refine_s (--refine)"),
        (["--fps", "120", "--method", "aca", "--restarts", "100000000"], "1..1000"),
    ],
)
def test_sizes_beyond_any_detector_are_one_line_not_a_memory_error(capsys, features, argv, said):
    line = _one_line(capsys, ["segment", features, *argv])
    assert said in line, line


def test_an_aca_segment_beyond_any_take_is_refused(capsys, features):
    """``--max-len 1e9`` asked the DP for 2.9 TiB."""
    line = _one_line(
        capsys, ["segment", features, "--fps", "120", "--method", "aca", "--max-len", "1e9"]
    )
    assert "--max-len" in line and "at most 416.667 s" in line, line


def test_eval_all_with_a_file_is_refused_not_ignored(capsys, data_dir):
    line = _one_line(
        capsys, ["eval", "--all", data_dir, data_dir / "cmu86" / "86_01.amc.gz", "--method", "lof"]
    )
    assert "86_01.amc.gz would be ignored" in line and "either --all DIR or FILE" in line


def test_batch_skips_what_it_cannot_read_and_a_rerun_with_the_missing_skeleton_runs_it(
    tmp_path, capsys, data_dir
):
    """An AMC without its ASF is skipped with the reason (exit 0: the other was segmented);
    rerun with ``--skeleton``, only that line runs again, and it is scored against its
    labels; a batch where nothing could be read exits 1."""
    import json
    import shutil

    from streamseg.cli import main

    lone = tmp_path / "exercise"
    lone.mkdir()
    shutil.copy(data_dir / "cmu_exercise" / "14_14.amc.gz", lone)
    shutil.copy(data_dir / "cmu_exercise" / "labels.csv", lone)
    files = [str(data_dir / "cmu86" / "86_01.amc.gz"), str(lone / "14_14.amc.gz")]
    out = tmp_path / "o.jsonl"
    batch = ["batch", *files, "--method", "lof", "--workers", "1", "--output", str(out)]
    batch += ["--labels", str(lone)]
    assert main(batch) == 0
    printed = capsys.readouterr()
    lines = {o["file"]: o for o in map(json.loads, out.read_text().splitlines())}
    assert lines[files[1]]["skipped"] is True and "--skeleton" in lines[files[1]]["error"]
    assert "2 recordings (2 run now, 0 already in" in printed.out
    assert "1 segmented; 1 skipped" in printed.out and "0 failed; 0 scored against" in printed.out
    assert main([*batch, "--skeleton", str(data_dir / "cmu86" / "86.asf")]) == 0
    printed = capsys.readouterr()
    assert "2 recordings (1 run now, 1 already in" in printed.out
    assert "2 segmented; 0 skipped" in printed.out and "0 failed; 1 scored against" in printed.out
    lines = {o["file"]: o for o in map(json.loads, out.read_text().splitlines())}
    assert len(lines) == 2 and "scores" in lines[files[1]]
    junk = tmp_path / "junk.amc"
    junk.write_text("not an amc\n")
    assert (
        main(["batch", str(junk), "--workers", "1", "--output", str(tmp_path / "j.jsonl")]) == 1
    )  # nothing segmented


@pytest.mark.daemon
def test_a_view_started_after_a_stream_closed_lists_it(start_daemon, rec):
    """``streamseg view --control`` beside a daemon whose stream has already ended: the
    ``streams`` reply names the closed streams and the view lists it, closed (end)."""
    pytest.importorskip("aiohttp")
    import dataclasses
    import json
    import urllib.request

    from streamseg.client import listen, request, subscribe
    from streamseg.commands.replay import replay
    from streamseg.view.server import ViewThread

    _, ep = start_daemon()
    s = subscribe(ep["publish"], ep["control"], stream="done")
    replay(
        dataclasses.replace(rec, positions=rec.positions[:600]),
        ep["ingest"],
        stream="done",
        speed=0,
        batch=60,
    )
    assert list(listen(s, stream="done", until_end=True, timeout=60))[-1].type == "closed"
    s.close()
    listed = request(ep["control"], "streams")
    assert listed["streams"] == []
    assert listed["closed"] == [{"stream": "done", "closed": "end", "frame": 600}]
    view = ViewThread(ep["publish"], ep["control"], poll=0.2)
    url = view.start()
    try:
        rows = wait_until(
            lambda: json.load(urllib.request.urlopen(url + "api/streams"))["rows"],
            "the view listed the closed stream",
        )
    finally:
        view.stop()
    assert [(r["stream"], r["closed"]) for r in rows] == [("done", "end")]


@pytest.mark.parametrize(
    "name", ["LOFSegmenter", "ACASegmenter", "ACA", "HACA", "RepetitionSegmenter"]
)
def test_every_offline_estimator_takes_config_then_fps(name):
    """One constructor convention (``streamseg.segments.Estimator``): (config=None,
    fps=120.0), then keywords with defaults."""
    import inspect

    import streamseg.offline as offline
    from streamseg.segments import Estimator

    cls = getattr(offline, name)
    assert issubclass(cls, Estimator)
    params = list(inspect.signature(cls).parameters.values())
    assert [(p.name, p.default) for p in params[:2]] == [("config", None), ("fps", 120.0)]
    assert all(p.default is not inspect.Parameter.empty for p in params)
    est = cls(None, 30.0)
    assert est.fps == 30.0 and est.config == type(est.config)()
