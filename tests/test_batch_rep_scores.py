"""`streamseg batch --method rep --labels` scores repetitions as `eval --method rep` does: per
labelled set (consecutive rows of one label; a lone row is an action, true count 0), each set's
repetitions matched to the found ones by overlap, not the i-th found with the i-th labelled."""

from __future__ import annotations

import json

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.commands.batch_tasks import score_object
from streamseg.evaluation.datasets import hdm05_clips
from streamseg.io import read, write_npz
from streamseg.recording import Recording


@pytest.fixture
def routine(data_dir, tmp_path):
    """Three squats then one throw (HDM05 actor bd) as one take, and its label rows."""
    asf = data_dir / "hdm05_reps" / "asf" / "HDM_bd.asf"
    clips = hdm05_clips(data_dir)
    recs = [read(clips["bd", "squat1Reps"][t], skeleton=asf) for t in range(3)]
    recs.append(read(clips["bd", "throwBasketball"][0], skeleton=asf))
    take = tmp_path / "take.npz"
    write_npz(take, Recording(120.0, recs[0].skeleton, np.concatenate([r.positions for r in recs])))
    ends = np.cumsum([r.n_frames for r in recs])
    rows = ["sequence,start_frame,end_frame,action_label"]
    for i, (a, b) in enumerate(zip([0, *ends[:-1]], ends)):
        rows.append(f"take,{a + 1},{b},{'squat' if i < 3 else 'throw'}")
    labels = tmp_path / "labels.csv"
    labels.write_text("\n".join(rows) + "\n")
    return take, labels


def test_batch_scores_a_take_as_eval_does(routine, tmp_path, capsys):
    pytest.importorskip("distributed", reason="batch needs the dask extra")
    take, labels = routine
    assert main(["eval", str(take), "--method", "rep", "--labels", str(labels), "--json"]) == 0
    said = json.loads(capsys.readouterr().out)
    out = tmp_path / "o.jsonl"
    assert (
        main(
            [
                "batch",
                str(take),
                "--method",
                "rep",
                "--labels",
                str(labels),
                "--workers",
                "1",
                "--output",
                str(out),
            ]
        )
        == 0
    )
    scores = json.loads(out.read_text().splitlines()[0])["scores"]
    assert said["true_count"] == 3 and said["exact_sets"] == "1 of 1"
    for key in (
        "alpha",
        "count",
        "true_count",
        "count_error",
        "exact_sets",
        "actions_counted_zero",
    ):
        assert scores[key] == pytest.approx(said[key]), key
    assert [s["true_count"] for s in scores["sets"]] == [3, 0]


def test_a_missed_repetition_shifts_no_other(tmp_path):
    # true repetitions of 100 frames; the first one is missed, the other two found exactly:
    # matched by overlap each found one is its true one (alpha 1); paired i-th with i-th,
    # the found second would be scored against the true first
    (tmp_path / "l.csv").write_text(
        "sequence,start_frame,end_frame,action_label\n"
        "t,1,100,squat\nt,101,220,squat\nt,221,300,squat\n"
    )
    found = [{"start": 100, "end": 220}, {"start": 220, "end": 300}]
    obj = {
        "n_frames": 300,
        "fps": 120.0,
        "count": 2,
        "repetitions": found,
        "sets": [{"start": 100, "end": 300, "count": 2, "repetitions": found}],
    }
    scores = score_object(obj, str(tmp_path / "l.csv"), "t")
    assert scores["alpha"] == pytest.approx(1.0)
    assert (scores["count"], scores["true_count"], scores["count_error"]) == (2, 3, -1)
    assert scores["exact_sets"] == "0 of 1"
