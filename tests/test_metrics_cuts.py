"""Cut precision/recall/F1, covering and latency statistics on hand-worked examples."""

from __future__ import annotations

import math

import numpy as np
import pytest

from streamseg.evaluation.metrics import (
    covering,
    cut_scores,
    cut_windows_from,
    latency_stats,
    match_cuts,
)


def test_flat_tolerance_hand_example():
    # true 100, 200; predicted 97 (hits 100), 150 (miss), 205 (hits 200), 206 (200 used)
    r = cut_scores([97, 150, 205, 206], [100, 200], tolerance=5)
    assert (r["tp"], r["n_pred"], r["n_true"]) == (2, 4, 2)
    assert r["precision"] == 0.5 and r["recall"] == 1.0
    assert r["f1"] == pytest.approx(2 * 0.5 * 1.0 / 1.5)


def test_each_true_cut_matched_at_most_once():
    r = cut_scores([99, 100, 101], [100], tolerance=10)
    assert r["tp"] == 1 and r["precision"] == pytest.approx(1 / 3)


def test_matching_is_maximal_not_greedy_nearest():
    # true 5 in [0, 12], true 11 in [10, 30]; predicted 10 and 25. Nearest-first would give 10
    # to true 11 (1 away) and leave 25 unmatched; giving 10 to the window that closes first
    # ([0, 12]) lets 25 match true 11: 2 matches, the maximum.
    pairs = match_cuts([10, 25], [5, 11], windows=[(0, 12), (10, 30)])
    assert sorted(pairs) == [(0, 0), (1, 1)]
    assert cut_scores([10, 25], [5, 11], windows=[(0, 12), (10, 30)])["f1"] == 1.0


def test_per_boundary_windows_and_margin():
    # window of the first cut is asymmetric [90, 130]; the second [200, 200]
    true, win = [100, 200], [(90, 130), (200, 200)]
    assert cut_scores([125, 203], true, windows=win)["tp"] == 1
    assert cut_scores([125, 203], true, windows=win, margin=3)["tp"] == 2
    assert cut_scores([86], true, windows=win, margin=3)["tp"] == 0
    np.testing.assert_array_equal(
        cut_windows_from(true, windows=win, margin=3), [[87, 133], [197, 203]]
    )


def test_empty_conventions():
    assert cut_scores([], [10], tolerance=5) == dict(
        precision=1.0, recall=0.0, f1=0.0, tp=0, n_pred=0, n_true=1
    )
    assert cut_scores([5], [], tolerance=5)["precision"] == 0.0
    with pytest.raises(ValueError, match="tolerance"):
        cut_scores([1], [1])


def test_covering_hand_example():
    # 10 frames, truth [0,4) [4,10); prediction [0,5) [5,10)
    # A=[0,4): best J = 4/5 with [0,5); A=[4,10): best J = 5/6 with [5,10)
    expected = (4 * 4 / 5 + 6 * 5 / 6) / 10
    assert covering([5], [4], 10) == pytest.approx(expected)
    assert covering([4], [4], 10) == 1.0
    # no predicted cut: one segment [0,10): (4*0.4 + 6*0.6) / 10
    assert covering([], [4], 10) == pytest.approx((4 * 0.4 + 6 * 0.6) / 10)


def test_latency_stats():
    s = latency_stats([10, 30, 20, 100])
    assert s == dict(n=4, median=25.0, mean=40.0, max=100.0)
    assert math.isnan(latency_stats([])["median"])
