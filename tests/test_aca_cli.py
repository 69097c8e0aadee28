"""``streamseg segment|eval --method aca`` and the plain-matrix reader."""

from __future__ import annotations

import json

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.exceptions import RecordingError
from streamseg.io.matrix import read_matrix

#: ACA on the hand-made flat sequence of these tests: three symbols, runs of 4 to 6 frames
FLAT_SEQUENCE = ("--method", "aca", "--fps", "1", "--flat", "--clusters", "3")
FLAT_SEQUENCE += ("--kernel", "equality", "--min-len", "4", "--max-len", "6")


def _sequence():
    # three classes, each a fixed pattern repeated; 60 rows
    a, b, c = [1, 2, 3, 4, 5], [9, 9, 8, 8, 7], [15, 12, 15, 12, 15]
    blocks = [a, a, b, b, c, c, a, a, b, b, c, c]
    x = np.concatenate([np.array(p, float) for p in blocks])
    truth = np.repeat([0, 0, 1, 1, 2, 2, 0, 0, 1, 1, 2, 2], 5)
    return x, truth


def test_read_matrix_npy_csv_and_errors(tmp_path):
    np.save(tmp_path / "m.npy", np.arange(6.0))
    assert read_matrix(tmp_path / "m.npy").shape == (6, 1)
    (tmp_path / "m.csv").write_text("a,b\n1,2\n\n3,4\n")
    np.testing.assert_array_equal(read_matrix(tmp_path / "m.csv"), [[1, 2], [3, 4]])
    (tmp_path / "bad.csv").write_text("1,2\n3,x\n")
    with pytest.raises(RecordingError, match=r"bad\.csv:2"):
        read_matrix(tmp_path / "bad.csv")
    (tmp_path / "ragged.csv").write_text("1,2\n3\n")
    with pytest.raises(RecordingError, match=r"ragged\.csv:2.*2 columns"):
        read_matrix(tmp_path / "ragged.csv")
    (tmp_path / "nan.csv").write_text("1\nnan\n")
    with pytest.raises(RecordingError, match=r"nan\.csv:2"):
        read_matrix(tmp_path / "nan.csv")
    with pytest.raises(RecordingError, match="suffix"):
        read_matrix(tmp_path / "m.txt")


def test_segment_matrix_json(tmp_path, capsys):
    x, truth = _sequence()
    np.save(tmp_path / "seq.npy", x)
    code = main(
        [
            "segment",
            str(tmp_path / "seq.npy"),
            *FLAT_SEQUENCE,
            "--restarts",
            "10",
            "--json",
        ]
    )
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert out["n_frames"] == 60 and out["fps"] == 1.0 and out["method"] == "aca"
    segs = out["segments"]
    assert segs[0]["start"] == 0 and segs[-1]["end"] == 60
    assert out["cuts"] == [s["start"] for s in segs[1:]]
    assert all(isinstance(s["label"], int) for s in segs)
    assert out["params"]["n_clusters"] == 3 and out["params"]["kernel"] == "equality"
    labels = np.concatenate([[s["label"]] * (s["end"] - s["start"]) for s in segs])
    from streamseg.evaluation.metrics import matched_frame_accuracy

    assert matched_frame_accuracy(labels, truth)[0] == 1.0


def test_eval_matrix_prints_accuracy_and_confusion(tmp_path, capsys):
    x, _ = _sequence()
    np.savetxt(tmp_path / "seq.csv", x[:, None], delimiter=",")
    rows = ["sequence,start_frame,end_frame,action_label"]
    for i, name in enumerate(["a", "b", "c", "a", "b", "c"]):
        rows.append(f"seq,{i * 10 + 1},{i * 10 + 10},{name}")
    (tmp_path / "labels.csv").write_text("\n".join(rows) + "\n")
    code = main(
        [
            "eval",
            str(tmp_path / "seq.csv"),
            *FLAT_SEQUENCE,
            "--json",
            "--labels",
            str(tmp_path / "labels.csv"),
        ]
    )
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert out["accuracy"] == 1.0
    C = np.array(out["confusion"])
    assert C.sum() == 60 and sorted(C.max(axis=1).tolist()) == [20, 20, 20]
    assert out["label_names"] == ["a", "b", "c"]


def test_segment_recording_with_plot(data_dir, tmp_path, capsys):
    png = tmp_path / "aca.png"
    code = main(
        [
            "segment",
            str(data_dir / "cmu86/86_01.amc.gz"),
            "--skeleton",
            str(data_dir / "cmu86/86.asf"),
            "--method",
            "aca",
            "--clusters",
            "4",
            "--restarts",
            "2",
            "--json",
            "--plot",
            str(png),
        ]
    )
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert out["n_frames"] == 4579 and out["fps"] == 120.0
    assert out["segments"][-1]["end"] == 4579
    assert png.stat().st_size > 1000


def test_bad_lengths_are_reported(tmp_path, capsys):
    np.save(tmp_path / "s.npy", np.arange(20.0))
    code = main(
        [
            "segment",
            str(tmp_path / "s.npy"),
            "--method",
            "aca",
            "--fps",
            "1",
            "--min-len",
            "5",
            "--max-len",
            "2",
        ]
    )
    assert code == 2
    assert "max_len" in capsys.readouterr().err


def test_k_is_found_without_clusters_and_long_matrices_are_reduced(tmp_path, capsys):
    x, _ = _sequence()
    np.save(tmp_path / "short.npy", x.astype(float)[:, None])
    assert (
        main(
            [
                "segment",
                str(tmp_path / "short.npy"),
                "--method",
                "aca",
                "--fps",
                "1",
                "--min-len",
                "4",
                "--max-len",
                "6",
                "--json",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert out["k_found"] and out["params"]["n_clusters"] is None
    assert out["n_clusters"] == int(max(out["k_scores"], key=out["k_scores"].get))
    assert out["params"]["k_reduce"] is None  # 60 rows: no reduction
    np.save(tmp_path / "long.npy", np.tile(x, 20).astype(float)[:, None])  # 1,200 rows
    assert (
        main(
            [
                "segment",
                str(tmp_path / "long.npy"),
                "--method",
                "aca",
                "--fps",
                "1",
                "--clusters",
                "3",
                "--restarts",
                "1",
                "--min-len",
                "4",
                "--max-len",
                "6",
                "--json",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert out["params"]["k_reduce"] == 20 and not out["k_found"] and out["n_clusters"] == 3


def test_a_still_recording_is_one_segment_with_a_note(tmp_path, capsys):
    np.save(tmp_path / "still.npy", np.ones((300, 4)))
    assert (
        main(["segment", str(tmp_path / "still.npy"), "--method", "aca", "--fps", "30", "--json"])
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert (
        out["segments"] == [{"start": 0, "end": 300, "label": 0, "start_s": 0.0, "end_s": 10.0}]
        and out["cuts"] == []
    )
    assert out["n_clusters"] == 1 and "no motion" in out["note"]
