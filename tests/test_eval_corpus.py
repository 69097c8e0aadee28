"""`streamseg eval --all data` reaches every labelled recording of docs/results.md: the CMU
takes with label CSVs and the sequences joined from the CMU 02 and HDM05 clips, in named sets,
and prints the per-set table the results quote."""

from __future__ import annotations

import json
from collections import Counter

import pytest

from streamseg.cli import main
from streamseg.evaluation.labelled_sets import labelled_sets


def test_the_bundled_data_holds_27_labelled_recordings_in_five_sets(data_dir):
    items = labelled_sets(data_dir)
    assert Counter(i.group for i in items) == {
        "cmu": 3,
        "cmu02": 2,
        "hdm": 9,
        "fresh": 9,
        "fresh2": 4,
    }
    assert len({i.name for i in items}) == 27
    for item in items:  # every joined part is labelled with its action, so labels score too
        assert item.segments[0].start == 0 and item.segments[-1].end == item.recording.n_frames
        assert item.n_actions >= 2, item.name
    # no clip is used by two joined sequences: the fresh sets stay held out
    sources = [
        s
        for i in items
        if i.group in ("hdm", "fresh", "fresh2")
        for s in i.recording.metadata["concatenated"]
    ]
    assert len(sources) == len(set(sources))


def test_unknown_set_is_one_line(capsys, data_dir):
    assert main(["eval", "--all", str(data_dir), "--sets", "cmu,nope"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown set 'nope'" in err[0]


@pytest.mark.slow
def test_eval_all_data_reproduces_the_cut_table(capsys, data_dir):
    argv = [
        "eval",
        "--all",
        str(data_dir),
        "--method",
        "lof",
        "--sets",
        "cmu,cmu02,hdm",
        "--chosen-on",
        "86_01,hdm_bd_0",
        "--json",
    ]
    assert main(argv) == 0
    out = json.loads(
        capsys.readouterr().out, parse_constant=lambda c: pytest.fail(f"non-strict JSON: {c}")
    )
    assert {r["set"] for r in out["rows"]} == {"cmu", "cmu02", "hdm"}
    assert {r["method"] for r in out["rows"]} == {"LOF streaming", "LOF offline"}
    summary = {(s["method"], s["set"]): s for s in out["summary"]}
    held = summary["LOF streaming", "held out (all but 86_01, hdm_bd_0)"]
    assert held["n"] == 12
    # docs/results.md (Cuts): held out 0.765, cmu 0.944, hdm 0.815; floors just below them
    assert held["f1"] >= 0.76
    assert summary["LOF streaming", "cmu"]["f1"] >= 0.94
    assert summary["LOF streaming", "hdm"]["f1"] >= 0.81
    assert 0 < summary["LOF streaming", "all"]["latency_median_s"] <= 2.5
    # offline segmentation makes the live decisions
    assert summary["LOF offline", "all"]["f1"] == summary["LOF streaming", "all"]["f1"]
