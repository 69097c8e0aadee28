"""Discovery of labelled recordings, scoring rows and `streamseg eval --all`."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.evaluation.corpus import (
    LabelledRecording,
    Prediction,
    discover,
    format_table,
    label_cuts,
    score,
    segments_from_cuts,
)
from streamseg.exceptions import RecordingError
from streamseg.recording import Recording, Skeleton


@pytest.fixture(scope="module")
def labelled(tmp_path_factory, data_dir):
    d = tmp_path_factory.mktemp("labelled")
    for f in ("86.asf", "86_01.amc.gz", "labels_86_01.csv"):
        shutil.copy(data_dir / "cmu86" / f, d / f)
    return d


def test_discover_reads_recording_and_labels(labelled):
    (item,) = discover(labelled)
    assert item.name == "86_01" and item.recording.n_frames == 4579
    assert item.cuts == [550, 1150, 1980, 2500, 3200, 4065]
    assert item.windows[0] == (499, 600)
    assert item.n_actions == 4  # walk, jump, punch, leg_kick


def test_discover_names_a_sequence_without_recording(tmp_path):
    (tmp_path / "labels.csv").write_text(
        "sequence,start_frame,end_frame,action_label\n99_01,1,10,walk\n"
    )
    with pytest.raises(
        RecordingError,
        match=r"labels.csv: found sequence '99_01' without a "
        r"recording",
    ):
        discover(tmp_path)


def _item(n=100, cuts=(40, 70)):
    skel = Skeleton(("root",), np.array([-1]), np.zeros((1, 3)))
    rec = Recording(10.0, skel, np.zeros((n, 1, 3)))
    return LabelledRecording("toy", rec, segments_from_cuts(list(cuts), n))


def test_score_by_hand():
    item = _item()
    # fps 10: window margin 0.5 s = 5 frames; cut 44 is inside [35, 45], 90 matches nothing
    row = score(item, Prediction(cuts=[44, 90], latencies=[3, 7]), fps=10.0)
    assert row["P"] == 0.5 and row["R"] == 0.5 and row["F1"] == 0.5
    assert row["lat_med"] == 5.0 and row["lat_max"] == 7.0
    assert np.isnan(row["acc"])
    labels = np.array([0] * 40 + [1] * 30 + [0] * 30)
    row = score(item, Prediction(cuts=label_cuts(labels), labels=labels), fps=10.0)
    assert row["F1"] == 1.0 and row["cover"] == 1.0
    assert row["acc"] == pytest.approx(0.7)  # truth has three labels, prediction two


def test_table_reports_errors_and_means():
    item = _item()
    rows = [
        ("toy", "a", score(item, Prediction(cuts=[40, 70]), 10.0)),
        ("toy", "b", score(item, Prediction(error="ImportError: no claspy"), 10.0)),
    ]
    text = format_table(rows)
    assert "| toy | b | could not run: ImportError: no claspy |" in text
    assert "| **mean (1)** | a | 1.000 | 1.000 | 1.000 |" in text


@pytest.mark.slow
def test_eval_all_cli(labelled, capsys):
    assert main(["eval", "--all", str(labelled), "--json"]) == 0
    out = json.loads(
        capsys.readouterr().out, parse_constant=lambda c: pytest.fail(f"non-strict JSON: {c}")
    )
    assert out["schema"] == 1 and out["command"] == "eval --all"
    rows = {r["method"]: r for r in out["rows"]}
    assert set(rows) == {
        "LOF offline",
        "LOF streaming",
        "ACA (K=true)",
        "HACA (K=true)",
        "HACA (K found)",
    }
    for r in rows.values():
        assert "error" not in r, r
        assert r["recording"] == "86_01"
    # the same key names as `eval --json` (docs/output.md), and the figures of 86_01, the
    # recording the defaults were chosen on (README): floors, not ranges
    assert rows["LOF streaming"]["f1"] >= 0.9 and rows["LOF offline"]["f1"] >= 0.9
    assert rows["LOF streaming"]["latency_median_frames"] > 0
    assert rows["LOF offline"]["latency_median_frames"] is None  # offline: no latency, null
    assert rows["HACA (K=true)"]["accuracy"] >= 0.8 and rows["HACA (K found)"]["accuracy"] >= 0.8
