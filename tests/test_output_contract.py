"""docs/output.md against what `segment` and `eval` print, for every method that segments."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from streamseg.cli import main

DOC = (Path(__file__).resolve().parents[1] / "docs" / "output.md").read_text()
COMMON = set(
    re.findall(r"^\| `(\w+)` \|", DOC.split("## `segment`")[1].split("Method keys")[0], re.M)
)


def _json(capsys, *argv) -> dict:
    assert main([str(a) for a in argv]) == 0
    captured = capsys.readouterr()
    return json.loads(captured.out, parse_constant=lambda c: pytest.fail(f"non-strict: {c}"))


@pytest.fixture(scope="module")
def recording(data_dir):
    return [data_dir / "cmu86" / "86_01.amc.gz", "--skeleton", data_dir / "cmu86" / "86.asf"]


@pytest.mark.parametrize(
    "argv",
    [
        ["--method", "lof"],
        ["--method", "lof", "--online"],
        ["--method", "aca"],
        ["--method", "rep"],
    ],
)
def test_segment_prints_the_documented_keys(capsys, recording, argv):
    out = _json(capsys, "segment", *recording, *argv, "--json")
    assert COMMON - {"plot", "events_file", "events_written"} <= set(out), COMMON - set(out)
    assert out["schema"] == 1 and out["command"] == "segment"
    segs = out["segments"]
    # the segments tile the frames, cuts are their starts, seconds are frames / fps
    assert segs[0]["start"] == 0 and segs[-1]["end"] == out["n_frames"] == 4579
    assert all(a["end"] == b["start"] for a, b in zip(segs[:-1], segs[1:]))
    assert out["cuts"] == [s["start"] for s in segs[1:]]
    assert out["cuts_s"] == [round(c / 120, 4) for c in out["cuts"]]
    assert all(s["end_s"] == round(s["end"] / 120, 4) for s in segs)
    if out["method"] == "lof":
        assert all(s["label"] is None for s in segs)
    elif out["method"] == "rep":  # the segments are the sets (their label) and the rest (None)
        for st in out["sets"]:
            assert any(
                s["start"] <= st["start"] and st["end"] <= s["end"] and s["label"] == st["label"]
                for s in segs
            )
        assert out["count"] == sum(st["count"] for st in out["sets"]) == len(out["repetitions"])
    else:  # same-label runs are merged: neighbours always differ
        assert all(a["label"] != b["label"] for a, b in zip(segs[:-1], segs[1:]))
        assert out["n_clusters"] == len({s["label"] for s in segs})
    for key in out:  # every key printed is documented
        assert f"`{key}`" in DOC, f"{key} is not in docs/output.md"


def test_eval_keys_are_the_documented_ones(capsys, recording, data_dir):
    labels = data_dir / "cmu86" / "labels_86_01.csv"
    for argv in (["--method", "lof", "--online"], ["--method", "aca", "--clusters", "labels"]):
        out = _json(capsys, "eval", *recording, "--labels", labels, *argv, "--json")
        assert out["command"] == "eval" and out["labels"] == str(labels)
        for key in out:
            assert f"`{key}`" in DOC, f"{key} is not in docs/output.md"
    assert out["n_clusters"] == out["n_true_actions"] == 4 and not out["k_found"]


def test_human_output_is_a_table_in_frames_and_seconds(capsys, recording, tmp_path):
    png = tmp_path / "x.png"
    assert main([str(a) for a in ["segment", *recording, "--plot", png]]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].endswith("lof, 6 cuts, 7 segments over 4579 frames (38.16 s at 120 fps)")
    assert out[1].split() == ["#", "start", "end", "start", "s", "end", "s", "label"]
    assert out[2].split()[:3] == ["0", "0", out[3].split()[1]]
    assert out[-1] == f"wrote {png}" and png.stat().st_size > 10_000


def test_options_that_do_nothing_are_named(capsys, recording):
    out = _json(capsys, "segment", *recording, "--method", "aca", "--online", "--json")
    assert out["warnings"] == ["--online is a lof option: it does nothing with --method aca"]
    out = _json(capsys, "segment", *recording, "--clusters", "3", "--json")
    assert any("--clusters is a aca option" in w for w in out["warnings"])


def test_a_skeleton_given_to_a_file_that_carries_its_own_is_named(capsys, recording, tmp_path):
    from streamseg.io import read
    from streamseg.io.npz import write_npz

    f = tmp_path / "take.npz"
    write_npz(f, read(recording[0], skeleton=recording[2]))
    out = _json(capsys, "segment", f, "--skeleton", recording[2], "--json")
    assert out["warnings"] == [
        "--skeleton does nothing for take.npz: only AMC files take an "
        "ASF skeleton (BVH, C3D and .npz carry their own, positions are "
        "named by their header or --joints, matrices need none)"
    ]


def test_failures_are_one_line_with_exit_codes(capsys, recording, tmp_path):
    assert main([str(a) for a in ["segment", *recording, "--plot", tmp_path / "no" / "x.png"]]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "does not exist" in err[0]
    assert main(["segment", str(tmp_path / "missing.bvh")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "missing.bvh" in err[0]
    assert main(["serve", "--ingest", "localhost:5560"]) == 2
    assert "tcp://127.0.0.1:5560" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:  # no tcp://: argparse's usage error, one line
        main(["listen", "--from", "127.0.0.1:5561"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "tcp://127.0.0.1:5560" in err[0]
    assert (
        main([str(a) for a in ["replay", *recording, "--to", "tcp://127.0.0.1:9", "--speed", "-1"]])
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--speed -1.0 is invalid" in err[0]
    with pytest.raises(SystemExit) as info:  # argparse's own errors: one line too
        main(["segment", "x.amc", "--method", "bogus"])
    assert info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "invalid choice: 'bogus'" in err[0]
    import zmq

    taken = zmq.Context.instance().socket(zmq.PULL)
    port = taken.bind_to_random_port("tcp://127.0.0.1")
    try:
        assert (
            main(
                [
                    "serve",
                    "--ingest",
                    f"tcp://127.0.0.1:{port}",
                    "--publish",
                    "tcp://127.0.0.1:0",
                    "--control",
                    "tcp://127.0.0.1:0",
                ]
            )
            == 1
        )
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "in use" in err[0] and "another process" in err[0]
    finally:
        taken.close(0)


@pytest.mark.slow
def test_a_matrix_without_fps_is_said_and_info_reads_matrices(capsys, tmp_path):
    import numpy as np

    m = tmp_path / "f.csv"
    np.savetxt(m, np.repeat(np.eye(3), 40, axis=0), delimiter=",")
    for method in ("aca", "lof", "rep"):  # a matrix has no frame rate: every method asks
        assert main(["segment", str(m), "--method", method]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--fps" in err[0], err
    out = _json(
        capsys,
        "segment",
        m,
        "--method",
        "aca",
        "--fps",
        "1",
        "--clusters",
        "3",
        "--min-len",
        "20",
        "--max-len",
        "40",
        "--json",
    )
    assert out["fps"] == 1.0 and out["n_clusters"] == 3
    assert main(["info", str(m)]) == 0
    text = capsys.readouterr().out
    assert "frames:    120" in text and "columns:   3" in text


def test_listen_jsonl_writes_segments_as_objects():
    from streamseg import protocol as P
    from streamseg.commands.listen import json_event

    ev = P.Segments("s", 2, 0, 10, ((0, 4, 1), (4, 10, 0)), True, 0.5)
    out = json_event(ev)
    assert out["segments"] == [
        {"start": 0, "end": 4, "label": 1},
        {"start": 4, "end": 10, "label": 0},
    ]
    assert out["type"] == "segments" and out["revision"] == 2
