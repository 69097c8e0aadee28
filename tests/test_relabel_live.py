"""Live relabelling parts: K found, windows with nothing to cluster, stream-wide ids, cuts."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg.config import ACAConfig
from streamseg.offline.identity import MAX_PROTOTYPES, snap_to_cuts, stable_labels
from streamseg.offline.model_selection import fit_aca, piece_silhouette
from streamseg.offline.relabel import WindowSegmentation, relabel_window

FPS = 120.0


def _actions(levels, seconds=3.0, seed=0, d=6):
    """Blocks of a noisy cyclic motion around each level (radians), one block per level."""
    rng = np.random.default_rng(seed)
    n = int(seconds * FPS)
    t = np.arange(n)[:, None]
    return np.concatenate([lv + 0.3 * np.sin(2 * np.pi * t / 60 + np.arange(d))
                           + rng.normal(0, 0.02, (n, d)) for lv in levels])


@pytest.mark.parametrize("name,X", [
    ("still", np.ones((2400, 17))),
    ("near-constant", 1 + 1e-6 * np.random.default_rng(1).random((2400, 17))),
    ("tiny", np.random.default_rng(2).random((30, 17))),
    ("one frame", np.random.default_rng(3).random((1, 17))),
    ("all NaN", np.full((600, 17), np.nan)),
])
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
    from streamseg.metrics import matched_frame_accuracy

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


def test_a_returning_action_gets_its_old_id_from_memory():
    """Revision 1 sees A then B; revision 2 (no overlap) sees C then A again: A keeps its id,
    C gets a new one."""
    X = _actions([0.5, 1.5, 2.5, 0.5], seed=5)
    n = X.shape[0] // 4
    f1 = np.arange(0, 2 * n)
    r1 = stable_labels(WindowSegmentation(0, 2 * n, [(0, n, 0), (n, 2 * n, 1)], 2), None,
                       X[f1], f1)
    f2 = np.arange(2 * n, 4 * n)
    r2 = stable_labels(WindowSegmentation(2 * n, 4 * n, [(2 * n, 3 * n, 0), (3 * n, 4 * n, 1)],
                                          2), r1, X[f2], f2)
    a_id = r1.segments[0][2]
    assert r2.segments[1][2] == a_id
    assert r2.segments[0][2] not in {lab for _, _, lab in r1.segments}
    assert {p[0] for p in r2.prototypes} == {a_id, r1.segments[1][2], r2.segments[0][2]}


def test_memory_is_bounded():
    rng = np.random.default_rng(6)
    prev = None
    for i in range(MAX_PROTOTYPES + 10):
        X = rng.normal(10 * i, 0.01, (100, 3))
        f = np.arange(100 * i, 100 * i + 100)
        prev = stable_labels(WindowSegmentation(f[0], f[-1] + 1, [(f[0], f[-1] + 1, 0)], 1),
                             prev, X, f)
    assert len(prev.prototypes) == MAX_PROTOTYPES
    assert len({p[0] for p in prev.prototypes}) == MAX_PROTOTYPES


def test_boundaries_snap_to_live_cuts():
    segs = [(0, 100, 0), (100, 200, 1), (200, 300, 1), (300, 400, 2)]
    got = snap_to_cuts(segs, [95, 250, 340], radius=30)
    # 100 -> 95; 200 is a boundary inside one action (not moved); 300 has no cut within 30
    assert got == [(0, 95, 0), (95, 200, 1), (200, 300, 1), (300, 400, 2)]
    assert snap_to_cuts(segs, [], 30) == segs


def test_haca_search_shares_the_fine_level_and_equals_single_fits():
    from dataclasses import replace

    from streamseg.offline.relabel import model_from_config

    X = _actions([0.4, 1.4, 2.4], seed=7)
    cfg = ACAConfig(n_clusters=None)
    each = dict(model_from_config(cfg, FPS).fit_each(X, [2, 3, 4]))
    for k in (2, 3, 4):
        alone = model_from_config(replace(cfg, n_clusters=k), FPS).fit(X)
        np.testing.assert_array_equal(each[k].labels_, alone.labels_)
        assert each[k].segments_ == alone.segments_ and each[k].n_clusters == k
    assert each[2].fine_segments_ == each[4].fine_segments_
