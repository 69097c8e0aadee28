"""What a new user ran into (docs: /work/notes/audit.md of the audit): each bad input gets
one line on stderr saying what is wrong and how to fix it, with exit code 2, never an
``internal error`` or a traceback; and the small behaviours that were silent."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

from streamseg.cli import main
from tests.cli_words import FREE_PORTS, STREAMSEG


def _one_line(capsys, argv, code=2) -> str:
    """Run the real command; assert its exit code and that stderr is one error line."""
    try:
        got = main([str(a) for a in argv])
    except SystemExit as exit_:  # argparse's own usage errors
        got = exit_.code
    err = capsys.readouterr().err.strip().splitlines()
    assert got == code, err
    assert len(err) == 1, err
    assert "internal error" not in err[0] and "Traceback" not in err[0], err[0]
    assert ": error: " in err[0], err[0]
    return err[0]


@pytest.fixture(scope="module")
def amc(data_dir):
    return [data_dir / "cmu86" / "86_01.amc.gz", "--skeleton", data_dir / "cmu86" / "86.asf"]


def test_an_empty_npy_is_named_not_an_internal_error(capsys, tmp_path):
    (tmp_path / "empty.npy").write_bytes(b"")
    for cmd in (["segment"], ["info"]):
        line = _one_line(capsys, [*cmd, tmp_path / "empty.npy", "--fps", "120"])
        assert "empty.npy" in line and "numpy.save" in line


def test_a_csv_that_is_not_text_names_its_line(capsys, tmp_path):
    bad = tmp_path / "m.csv"
    bad.write_bytes(b"1,2\n3,4\n\xe9\xff,5\n")
    line = _one_line(capsys, ["segment", bad, "--fps", "120", "--method", "aca"])
    assert "m.csv:3" in line and "not UTF-8" in line


def test_label_files_that_are_not_text_or_not_1_based(capsys, tmp_path, amc):
    junk = tmp_path / "junk.csv"
    junk.write_bytes(b"sequence,start_frame,end_frame,action_label\n86_01,1,9,walk\n\xff\xfe\n")
    line = _one_line(capsys, ["eval", *amc, "--labels", junk])
    assert "junk.csv:3" in line and "not UTF-8" in line
    zero = tmp_path / "zero.csv"  # frame 0 in a 1-based file: its segment would be empty
    zero.write_text("sequence,start_frame,end_frame,action_label\n86_01,0,100,walk\n")
    line = _one_line(capsys, ["eval", *amc, "--labels", zero])
    assert "zero.csv:2" in line and "1-based" in line


def test_eval_all_skips_a_csv_that_is_not_text(capsys, tmp_path):
    (tmp_path / "blob.csv").write_bytes(bytes(range(128, 256)) * 4)
    line = _one_line(capsys, ["eval", "--all", tmp_path])
    assert "no label CSVs" in line


@pytest.mark.parametrize("value", ["inf", "0", "-1", "nan", "abc"])
def test_fps_must_be_a_finite_positive_number(capsys, tmp_path, value):
    m = tmp_path / "x.npy"
    np.save(m, np.zeros((50, 17)))
    line = _one_line(capsys, ["segment", m, "--fps", value])
    assert f"--fps: '{value}'" in line and "finite number > 0" in line


@pytest.mark.parametrize(
    "argv, said",
    [
        (["--stream", "walk/1"], "not a valid stream id"),
        (["--stream", ""], "not a valid stream id"),
        (["--wait", "0"], "--wait 0 is invalid"),
        (["--labels", "nosuch.csv"], "--labels nosuch.csv: no such file"),
    ],
)
def test_replay_refuses_what_the_daemon_would_drop(capsys, amc, argv, said):
    # checked before connecting: the port is not a daemon, so nothing would ever be sent
    line = _one_line(capsys, ["replay", *amc, "--to", "tcp://127.0.0.1:9", *argv])
    assert said in line


def test_replay_labels_without_the_stream_sequence(capsys, amc, data_dir):
    line = _one_line(
        capsys,
        [
            "replay",
            *amc,
            "--to",
            "tcp://127.0.0.1:9",
            "--labels",
            data_dir / "cmu_exercise" / "labels.csv",
        ],
    )
    assert "no rows for sequence '86_01'" in line


def test_default_stream_ids_are_ascii():
    from streamseg import protocol
    from streamseg.commands.replay import stream_id

    assert stream_id("/takes/café walk.amc.gz") == "caf__walk"
    assert protocol.valid_stream_id(stream_id("/takes/café walk.amc.gz"))
    assert stream_id("86_01.amc.gz") == "86_01"


@pytest.mark.parametrize(
    "argv, said",
    [
        (["--control", "tcp://127.0.0.1:9", "--stream", "s", "--since", "-5"], "--since -5"),
        (["--count", "0"], "--count 0"),
        (["--timeout", "-1"], "--timeout -1"),
        (["--idle", "0"], "--idle 0"),
    ],
)
def test_listen_refuses_bad_numbers_before_connecting(capsys, argv, said):
    line = _one_line(capsys, ["listen", "--from", "tcp://127.0.0.1:9", *argv])
    assert said in line and "is invalid" in line


def test_serve_refuses_a_state_dir_that_is_a_file_and_a_bad_http_before_binding(capsys, tmp_path):
    afile = tmp_path / "afile"
    afile.write_text("x")
    free = FREE_PORTS
    line = _one_line(capsys, ["serve", *free, "--state-dir", afile / "sub"])
    assert "is a file, not a folder" in line
    out = capsys.readouterr().out
    assert main(["serve", *free, "--state-dir", "none", "--http", "127.0.0.1:99999"]) == 2
    captured = capsys.readouterr()
    assert "--http" in captured.err and "ingest=" not in out + captured.out  # nothing bound


def test_view_refuses_a_non_positive_interval(capsys):
    line = _one_line(capsys, ["view", "--from", "tcp://127.0.0.1:9", "--interval", "0"])
    assert "--interval 0 is invalid" in line


def test_too_many_clusters_is_said_not_silently_one(capsys, tmp_path):
    m = tmp_path / "two.npy"
    rng = np.random.default_rng(0)
    np.save(m, np.vstack([rng.normal(0, 0.1, (60, 3)), rng.normal(3, 0.1, (60, 3))]))
    assert (
        main(
            [
                "segment",
                str(m),
                "--method",
                "aca",
                "--fps",
                "10",
                "--clusters",
                "50",
                "--min-len",
                "2",
                "--max-len",
                "4",
                "--json",
            ]
        )
        == 0
    )
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert out["n_clusters"] != 50
    assert any("--clusters 50" in w and "at most 6" in w for w in out["warnings"])
    assert "--clusters 50" in captured.err


def test_aca_on_a_position_only_recording_runs_with_a_warning(capsys, tmp_path, rec):
    import dataclasses

    from streamseg.io import write_npz

    f = tmp_path / "positions.npz"
    write_npz(f, dataclasses.replace(rec, positions=rec.positions[:1200], rotations=None))
    assert main(["segment", str(f), "--method", "aca", "--json"]) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert out["segments"][-1]["end"] == 1200
    assert any("positions only" in w for w in out["warnings"])


def test_rep_table_shows_each_set_count(capsys, tmp_path, rec):
    from streamseg.commands.output import format_segmentation

    result = {
        "file": "t",
        "method": "rep",
        "n_frames": 200,
        "fps": 10.0,
        "cuts": [10],
        "segments": [
            {"start": 0, "end": 10, "label": None, "start_s": 0, "end_s": 1},
            {"start": 10, "end": 200, "label": 1, "start_s": 1, "end_s": 20},
        ],
        "sets": [
            {
                "start": 10,
                "end": 200,
                "label": 1,
                "count": 4,
                "tempo_min_s": 4.5,
                "tempo_max_s": 5.25,
                "confidence": 0.8,
            }
        ],
        "count": 4,
    }
    lines = format_segmentation(result).splitlines()
    assert lines[1].split() == [
        "set",
        "start",
        "s",
        "end",
        "s",
        "label",
        "count",
        "s",
        "per",
        "repetition",
        "confidence",
    ]
    assert lines[2].split() == ["0", "1.00", "20.00", "1", "4", "4.50-5.25", "0.80"]


def test_info_names_the_file_given(capsys, tmp_path, rec):
    from streamseg.io import write_npz

    f = tmp_path / "take.npz"
    write_npz(f, rec)
    assert main(["info", str(f)]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith(f"file:      {f}") and "converted from" in first


def test_no_traceback_from_the_installed_command(tmp_path):
    """The console script itself, as a user runs it: one line, exit 2."""
    (tmp_path / "empty.npy").write_bytes(b"")
    run = subprocess.run(
        [
            *STREAMSEG,
            "segment",
            str(tmp_path / "empty.npy"),
            "--fps",
            "120",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 2 and run.stdout == ""
    assert len(run.stderr.strip().splitlines()) == 1 and "Traceback" not in run.stderr


def test_keys_refuses_fewer_than_one_client(capsys, tmp_path):
    line = _one_line(capsys, ["keys", tmp_path / "k", "--clients", "0"])
    assert "--clients 0 is invalid" in line
    assert not (tmp_path / "k").exists()


def test_a_missing_skeleton_is_not_called_a_recording(capsys, data_dir, tmp_path):
    line = _one_line(
        capsys,
        ["segment", data_dir / "cmu86" / "86_01.amc.gz", "--skeleton", tmp_path / "nosuch.asf"],
    )
    assert "nosuch.asf: found no such file" in line and "recording" not in line


def test_a_one_frame_warning_is_singular(capsys, tmp_path):
    m = tmp_path / "one.npy"
    np.save(m, np.zeros((1, 17)))
    assert main(["segment", str(m), "--fps", "120", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert any(w.startswith("the recording has 1 frame (") for w in out["warnings"])


@pytest.mark.parametrize(
    "url", ["tcp://127.0.0.1:99999", "tcp://127.0.0.1", "127.0.0.1:5560", "tcp://:5560"]
)
def test_an_endpoint_that_cannot_be_reached_is_refused_at_once(capsys, amc, url):
    """ZeroMQ accepts a port beyond 65535 and would wait for a daemon that cannot exist."""
    for argv in (
        ["replay", amc[0], *amc[1:], "--to", url],
        ["listen", "--from", url],
        ["listen", "--from", "tcp://127.0.0.1:5561", "--control", url],
    ):
        line = _one_line(capsys, argv)
        assert repr(url) in line and "tcp://HOST:PORT" in line


def test_labels_past_the_recordings_end_are_said(capsys, amc, data_dir, tmp_path):
    """A label file of a longer take is clipped to the recording, with a warning in the JSON
    and on stderr; the label file of the take itself gives none."""
    labels = data_dir / "cmu86" / "labels_86_01.csv"
    longer = tmp_path / "labels.csv"
    longer.write_text(labels.read_text() + "86_01,4580,99999,walk,4500,4600\n")
    for method in ("lof", "aca"):
        assert (
            main(["eval", *map(str, amc), "--labels", str(longer), "--method", method, "--json"])
            == 0
        )
        out = json.loads(capsys.readouterr().out)
        said = [w for w in out["warnings"] if "past the recording" in w]
        assert len(said) == 1 and "reach frame 99999" in said[0] and "4579 frames" in said[0]
    assert main(["eval", *map(str, amc), "--labels", str(labels), "--json"]) == 0
    assert not [
        w for w in json.loads(capsys.readouterr().out)["warnings"] if "past the recording" in w
    ]


def test_listens_state_line_counts_runs_like_its_relabel_lines():
    """The late joiner's state line and the relabel lines speak of the same unit."""
    from streamseg import protocol
    from streamseg.commands.listen import _state_line, format_event

    pieces = [[0, 100, 1], [100, 200, 1], [200, 300, 2]]  # two cycles of action 1, then 2
    state = {
        "stream": "s",
        "frame": 300,
        "revision": 2,
        "cuts": [],
        "segments": {"start": 0, "end": 300, "segments": pieces},
    }
    ev = protocol.Segments("s", 2, 0, 300, [tuple(p) for p in pieces], 0.01, False)
    assert "2 runs of 2 labels over 0-300" in _state_line(state)
    assert "2 runs of 2 labels" in format_event(ev)


def test_clusters_that_hold_no_segment_are_said(capsys, amc):
    """K = 40 on a take of four actions leaves clusters empty: the JSON's n_clusters is what
    was asked, the warning says how many hold a segment."""
    assert main(["segment", *map(str, amc), "--method", "aca", "--clusters", "40", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    used = len({s["label"] for s in out["segments"]})
    assert out["n_clusters"] == 40 and used < 40
    assert out["warnings"] == [
        f"only {used} of the 40 clusters hold a segment: the frames "
        "separate into fewer actions than --clusters 40 (omit "
        "--clusters to have K found)"
    ]
    assert main(["segment", *map(str, amc), "--method", "aca", "--clusters", "4", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["warnings"] == []
