"""Hungarian-matched frame accuracy and the eq. 11 confusion matrix, on hand-worked cases."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg.evaluation.metrics import frame_confusion, matched_frame_accuracy
from streamseg.exceptions import ParameterError


def test_confusion_counts_shared_frames():
    pred = [0, 0, 0, 1, 1, 2, 2, 2]
    truth = ["a", "a", "b", "b", "b", "b", "c", "c"]
    C, pl, tl = frame_confusion(pred, truth)
    # rows 0,1,2; columns a,b,c: pred 0 covers a,a,b; pred 1 covers b,b; pred 2 covers b,c,c
    np.testing.assert_array_equal(C, [[2, 1, 0], [0, 2, 0], [0, 1, 2]])
    assert pl.tolist() == [0, 1, 2] and tl.tolist() == ["a", "b", "c"]


def test_hungarian_accuracy_hand_example():
    pred = [0, 0, 0, 1, 1, 2, 2, 2]
    truth = ["a", "a", "b", "b", "b", "b", "c", "c"]
    acc, mapping = matched_frame_accuracy(pred, truth)
    # best one-to-one matching: 0->a (2), 1->b (2), 2->c (2) = 6 of 8 frames
    assert acc == pytest.approx(6 / 8)
    assert mapping == {0: "a", 1: "b", 2: "c"}


def test_matching_is_one_to_one_not_greedy():
    # greedy (largest cell first) would take 0 -> x (3) and leave 1 -> y (0)
    pred = [0, 0, 0, 0, 1, 1, 1]
    truth = ["x", "x", "x", "y", "x", "x", "x"]
    # C = [[3, 1], [3, 0]]: options 3+0 = 3 or 1+3 = 4 -> 4/7
    acc, mapping = matched_frame_accuracy(pred, truth)
    assert acc == pytest.approx(4 / 7)
    assert mapping == {0: "y", 1: "x"}


def test_more_clusters_than_labels_and_permutation_invariance():
    truth = np.array([0, 0, 1, 1, 1, 2])
    assert matched_frame_accuracy(truth + 5, truth)[0] == 1.0
    pred = np.array([0, 1, 2, 2, 2, 3])  # 4 clusters for 3 labels: one cluster unmatched
    assert matched_frame_accuracy(pred, truth)[0] == pytest.approx(5 / 6)


def test_length_mismatch_is_an_error():
    with pytest.raises(ParameterError, match="same frames"):
        matched_frame_accuracy([0, 1], [0, 1, 1])
