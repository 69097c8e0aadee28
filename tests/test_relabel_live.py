"""Live relabelling parts: K found, windows with nothing to cluster, stream-wide ids, cuts."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg.config import ACAConfig
from streamseg.offline.identity import snap_to_cuts, stable_labels
from streamseg.offline.model_selection import fit_aca, piece_silhouette
from streamseg.offline.relabel import WindowSegmentation, relabel_window
from tests.motion import FPS, cyclic_blocks


def _actions(levels, seconds=3.0, seed=0, d=6):
    return cyclic_blocks(levels, seconds, seed, d)


@pytest.mark.parametrize(
    "name,X",
    [
        ("still", np.ones((2400, 17))),
        ("near-constant", 1 + 1e-6 * np.random.default_rng(1).random((2400, 17))),
        ("tiny", np.random.default_rng(2).random((30, 17))),
        ("one frame", np.random.default_rng(3).random((1, 17))),
        ("all NaN", np.full((600, 17), np.nan)),
    ],
)
def test_windows_with_nothing_to_cluster_are_one_segment(name, X):
    w = relabel_window(X, start_frame=100, fps=FPS, config=ACAConfig())
    assert w.segments == [(100, 100 + X.shape[0], w.segments[0][2])]
    assert w.n_clusters == 1


def test_nan_riddled_window_keeps_every_frame_and_its_actions():
    X = _actions([0.5, 1.5, 2.5])
    truth = np.repeat([0, 1, 2], X.shape[0] // 3)
    holey = X.copy()
    rng = np.random.default_rng(4)
    holey[rng.random(X.shape[0]) < 0.2, rng.integers(0, X.shape[1])] = np.nan
    holey[:5] = np.nan  # the first frames too
    got = fit_aca(holey, ACAConfig(n_clusters=3), FPS)
    assert got.labels_.shape == (X.shape[0],) and (got.labels_ >= 0).all()
    segs = got.segments_
    assert segs[0][0] == 0 and segs[-1][1] == X.shape[0]
    assert all(a[1] == b[0] for a, b in zip(segs, segs[1:]))
    # the three blocks are still found (0.90 without the holes)
    from streamseg.evaluation.metrics import matched_frame_accuracy

    assert matched_frame_accuracy(got.labels_, truth)[0] >= 0.85


def test_k_is_found_on_distinct_actions():
    X = _actions([0.4, 1.4, 2.4, 0.9])
    fitted = fit_aca(X, ACAConfig(), FPS)
    assert fitted.n_clusters_ == 4 and set(fitted.scores_) == set(range(2, 9))
    assert max(fitted.scores_, key=fitted.scores_.get) == 4


def test_silhouette_is_high_for_the_true_partition_and_needs_two_labels():
    X = _actions([0.5, 2.0])
    n = X.shape[0] // 2
    right = np.repeat([0, 1], n)
    stripes = (np.arange(2 * n) // 60) % 2  # a labelling that cuts across both actions
    assert piece_silhouette(X, np.zeros(2 * n, dtype=np.int64), 120) == -1.0
    assert piece_silhouette(X, right, 120) > 0.5 > piece_silhouette(X, stripes, 120)


def test_ids_are_never_reused_for_the_life_of_a_stream():
    """Revision 1 holds actions 0, 1; revision 2 (overlapping only action 1) holds 1 and a new
    one; revision 3 (no overlap) holds two new clusters: each new cluster gets an id the
    stream never used, even one the previous revision no longer holds."""
    r1 = stable_labels(WindowSegmentation(0, 200, [(0, 100, 5), (100, 200, 9)], 2), None)
    assert [lab for *_, lab in r1.segments] == [0, 1] and r1.next_id == 2
    r2 = stable_labels(WindowSegmentation(100, 300, [(100, 200, 0), (200, 300, 1)], 2), r1)
    assert [lab for *_, lab in r2.segments] == [1, 2] and r2.next_id == 3
    r3 = stable_labels(WindowSegmentation(400, 600, [(400, 500, 0), (500, 600, 1)], 2), r2)
    assert [lab for *_, lab in r3.segments] == [3, 4] and r3.next_id == 5


def test_boundaries_snap_to_live_cuts():
    segs = [(0, 100, 0), (100, 200, 1), (200, 300, 1), (300, 400, 2)]
    got = snap_to_cuts(segs, [95, 250, 340], radius=30)
    # 100 -> 95; 200 is a boundary inside one action (not moved); 300 has no cut within 30
    assert got == [(0, 95, 0), (95, 200, 1), (200, 300, 1), (300, 400, 2)]
    assert snap_to_cuts(segs, [], 30) == segs


def test_haca_search_shares_the_fine_level_and_equals_single_fits():
    from dataclasses import replace

    from streamseg.offline.model_selection import model_from_config

    X = _actions([0.4, 1.4, 2.4], seed=7)
    cfg = ACAConfig(n_clusters=None)
    each = dict(model_from_config(cfg, FPS).fit_each(X, [2, 3, 4]))
    for k in (2, 3, 4):
        alone = model_from_config(replace(cfg, n_clusters=k), FPS).fit(X)
        np.testing.assert_array_equal(each[k].labels_, alone.labels_)
        assert each[k].segments_ == alone.segments_ and each[k].n_clusters == k
    assert each[2].fine_segments_ == each[4].fine_segments_
