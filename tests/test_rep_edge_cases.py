"""Honest answers where there is nothing to count (issue 14): one repetition, a frozen
recording, a take of one non-repetitive action: count 0 and ``repetitive: false`` in the
JSON and in the picture's title, not only on stderr.

Real HDM05 clips of actor bd (data/hdm05_reps): each clip holds one repetition or one action.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.io import read, write_npz
from streamseg.offline.repetition import RepetitionSegmenter
from streamseg.plotting.repetitions import title
from streamseg.recording import Recording


def _clip(data_dir, cls, take="001"):
    asf = data_dir / "hdm05_reps" / "asf" / "HDM_bd.asf"
    return read(data_dir / "hdm05_reps" / cls / f"HDM_bd_{cls}_{take}_120.amc.gz", skeleton=asf)


@pytest.mark.parametrize("cls", ["squat1Reps", "kickLFront1Reps", "depositFloorR",
                                 "throwBasketball"])
def test_one_movement_is_not_counted(data_dir, cls):
    """One squat (one repetition) or one deposit / throw (one action): count 0, not repetitive,
    and the title says so."""
    seg = RepetitionSegmenter().fit(_clip(data_dir, cls))
    assert seg.count_ == 0 and seg.repetitions_ == []
    assert seg.repetitive_ is False and seg.reason_
    assert title(seg).startswith("not repetitive: 0 repetitions")


def test_a_frozen_recording_has_no_repetitions(data_dir):
    rec = _clip(data_dir, "squat1Reps")
    frozen = Recording(rec.fps, rec.skeleton, np.repeat(rec.positions[:1], 600, axis=0))
    seg = RepetitionSegmenter().fit(frozen)
    assert seg.count_ == 0 and seg.repetitive_ is False and seg.reason_ == "no motion"
    noisy = Recording(rec.fps, rec.skeleton, frozen.positions + np.random.default_rng(0).normal(
        0, 0.01, frozen.positions.shape))  # 1 cm sensor noise on a still body
    seg = RepetitionSegmenter().fit(noisy)
    assert seg.count_ == 0 and seg.repetitive_ is False


@pytest.mark.parametrize("kind", ["single squat", "frozen"])
def test_cli_json_and_plot_say_not_repetitive(data_dir, tmp_path, capsys, kind):
    rec = _clip(data_dir, "squat1Reps")
    if kind == "frozen":
        rec = Recording(rec.fps, rec.skeleton, np.repeat(rec.positions[:1], 600, axis=0))
    path = tmp_path / "take.npz"
    write_npz(path, rec)
    png = tmp_path / "take.png"
    assert main(["segment", str(path), "--method", "rep", "--json", "--plot", str(png)]) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert out["count"] == 0 and out["repetitions"] == [] and out["repetitive"] is False
    assert out["reason"]
    assert all(st["count"] == 0 and st["repetitive"] is False for st in out["sets"])
    assert out["sets"][0]["start"] == 0 and out["sets"][-1]["end"] == rec.n_frames
    assert "does not look repetitive" in captured.err
    assert png.stat().st_size > 5_000
