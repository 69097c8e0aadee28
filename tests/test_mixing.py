"""Temporal mixing (``model_selection.merge_interleaved``): clusters that alternate within a
short window are one action; an action that returns once after another is not merged."""

from __future__ import annotations

import numpy as np

from streamseg.offline.model_selection import merge_interleaved, mixing_counts


def _runs(*pairs):
    return np.concatenate([np.full(n, lab) for lab, n in pairs])


def test_alternating_sub_movements_are_counted_and_merged():
    # 0 and 1 alternate (gaps of 2 frames); 2 and 3 are contiguous actions after them
    lab = _runs((0, 5), (1, 2), (0, 2), (1, 2), (0, 3), (2, 20), (3, 5), (2, 30))
    N = mixing_counts(lab, 3)
    assert N[0, 1] == N[1, 0] == 3  # 0 returns twice across 1, 1 once across 0
    assert N[2, 3] == 0  # 2's return across 3 is 5 frames apart, beyond the window
    merged = merge_interleaved(lab, 3, 2)
    assert np.array_equal(merged, _runs((0, 14), (1, 20), (2, 5), (1, 30)))


def test_one_return_across_another_action_does_not_merge():
    # walk / jump / walk / run / walk (86_01's shape): each pair interleaves once
    lab = _runs((0, 50), (1, 40), (0, 60), (2, 30), (0, 50))
    N = mixing_counts(lab, 100)
    assert N[0, 1] == N[0, 2] == 1 and N[1, 2] == 0
    assert np.array_equal(merge_interleaved(lab, 100, 2), lab)


def test_returns_of_three_cyclic_sub_movements_count_for_every_pair():
    lab = np.tile(_runs((0, 3), (1, 3), (2, 3)), 4)
    N = mixing_counts(lab, 6)
    assert N[0, 1] >= 2 and N[0, 2] >= 2 and N[1, 2] >= 2
    # the floor: never fewer than min_clusters clusters
    assert np.unique(merge_interleaved(lab, 6, 2)).size == 2
    assert np.unique(merge_interleaved(lab, 6, 2, min_clusters=1)).size == 1


def test_labels_are_renumbered_by_first_appearance_and_edge_cases_hold():
    lab = _runs((5, 4), (2, 4), (7, 4))
    assert np.array_equal(merge_interleaved(lab, 10, 2), _runs((0, 4), (1, 4), (2, 4)))
    assert merge_interleaved(np.zeros(0, dtype=int), 10, 2).size == 0
    assert np.array_equal(merge_interleaved(np.zeros(6, dtype=int), 10, 1), np.zeros(6))
    assert mixing_counts(np.zeros(6, dtype=int), 10).tolist() == [[0]]
