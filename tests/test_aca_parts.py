"""ACA pieces: initializations (section 4.2), temporal reduction (4.1), HACA, windowed relabel."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from streamseg.config import ACAConfig
from streamseg.evaluation.metrics import matched_frame_accuracy
from streamseg.exceptions import ParameterError
from streamseg.offline import HACAEngine, WindowSegmentation, relabel_window, warmup
from streamseg.offline.aca import ACAEngine
from streamseg.offline.aca_init import (
    kmeans,
    propagated_similarity,
    random_tiling,
    runs_to_segments,
    spectral_labels,
)
from streamseg.offline.reduction import expand_labels, reduce_frames
from streamseg.offline.relabel import match_labels


def test_random_tiling_respects_lengths():
    rng = np.random.default_rng(0)
    for n in (10, 37, 100):
        s, e = random_tiling(n, 4, 7, rng)
        assert s[0] == 0 and e[-1] == n and np.array_equal(s[1:], e[:-1])
        assert np.all((e - s >= 4) & (e - s <= 7))


@pytest.mark.parametrize("w", [1, 2, 5, 15])
def test_random_tiling_of_one_length_is_the_loops_and_draws_nothing(w):
    from tests.naive import naive_random_tiling

    for n in range(0, 4 * w + 3):
        rng, ref = np.random.default_rng(n), np.random.default_rng(n)
        got, want = random_tiling(n, w, w, rng), naive_random_tiling(n, w, w, ref)
        assert all(np.array_equal(a, b) and a.dtype == b.dtype for a, b in zip(got, want))
        assert rng.bit_generator.state == ref.bit_generator.state


def test_propagated_similarity_hand_example():
    # classes a b a b (n = 4), wmax = 1. kappa: same class -> (0,2), (1,3) and the diagonal.
    # d = 1: pairs (i1, i2) with c[i1] == c[i2] and c[i1-1] == c[i2-1]: (1, 3), (3, 1), (2, 2),
    # (1, 1), (3, 3) ... adds (i1, i1-1) for every i1 >= 1 (band) and (1, 3-1) = (1, 2),
    # (3, 0) from (i1, i2 - d), and (0, 3), (2, 1) from (i1 - d, i2); symmetric closure.
    S = propagated_similarity(np.array([0, 1, 0, 1]), 1)
    expected = np.array([[1, 1, 1, 1], [1, 1, 1, 1], [1, 1, 1, 1], [1, 1, 1, 1]])
    np.testing.assert_array_equal(S, expected)
    # two unrelated classes far apart stay unlinked beyond the band
    S = propagated_similarity(np.array([0, 0, 0, 1, 1, 1]), 1)
    assert S[0, 5] == 0 and S[0, 3] == 0 and S[2, 3] == 1 and S[3, 5] == 1


def test_runs_to_segments_splits_and_merges():
    lab = np.array([0] * 10 + [1] * 2 + [2] * 5)
    s, e, c = runs_to_segments(lab, 3, 5)
    # run of 10 -> 5 + 5; run of 2 (< 3) merged into the previous piece; run of 5 kept
    assert list(zip(s, e, c)) == [(0, 5, 0), (5, 12, 0), (12, 17, 2)]


def test_spectral_and_kmeans_separate_blocks():
    rng = np.random.default_rng(1)
    A = np.kron(np.eye(3), np.ones((5, 5))) + 0.01
    lab = spectral_labels(A, 3, rng)
    assert matched_frame_accuracy(lab, np.repeat([0, 1, 2], 5))[0] == 1.0
    X = np.concatenate([rng.normal(0, 0.1, (20, 2)), rng.normal(5, 0.1, (20, 2))])
    assert matched_frame_accuracy(kmeans(X, 2, rng), np.repeat([0, 1], 20))[0] == 1.0


def test_reduction_merges_runs_with_cap_and_maps_back():
    X = np.concatenate([np.zeros((7, 2)), np.ones((3, 2)), np.zeros((2, 2))])
    Xr, (s, e), classes = reduce_frames(X, 2, 4, np.random.default_rng(0))
    # runs 7 (cut at cap 4 -> 4 + 3), 3, 2
    assert s.tolist() == [0, 4, 7, 10] and e.tolist() == [4, 7, 10, 12]
    np.testing.assert_array_equal(Xr, [[0, 0], [0, 0], [1, 1], [0, 0]])
    assert classes[0] == classes[1] == classes[3] != classes[2]
    np.testing.assert_array_equal(
        expand_labels([5, 6, 7, 8], (s, e), 12), [5] * 4 + [6] * 3 + [7] * 3 + [8] * 2
    )


def _blocks(rng, pattern, reps):
    """Sequence of actions, each a noisy repetition of a 2-D cyclic pattern."""
    shapes = {
        0: lambda t: np.c_[np.sin(t), np.cos(t)],
        1: lambda t: np.c_[3 + np.sin(2 * t), t * 0],
        2: lambda t: np.c_[t * 0 - 3, np.cos(3 * t)],
    }
    xs, ys = [], []
    for c in pattern:
        t = np.linspace(0, 2 * np.pi * reps, 40 * reps, endpoint=False)
        xs.append(shapes[c](t) + rng.normal(0, 0.05, (t.size, 2)))
        ys.append(np.full(t.size, c))
    return np.concatenate(xs), np.concatenate(ys)


def test_aca_with_reduction_and_propagated_init_on_blocks():
    X, y = _blocks(np.random.default_rng(0), [0, 1, 2, 0, 1], 3)
    full = ACAEngine(3, 30, 80, n_init=5, init="propagated", random_state=0).fit(X)
    assert matched_frame_accuracy(full.labels_, y)[0] == 1.0
    # reduction squeezes actions unevenly (a run of one k-means class is one unit whatever its
    # duration), so it costs some accuracy here; chance level is about 0.4
    model = ACAEngine(
        3, 30, 80, n_init=5, k_reduce=20, reduce_cap=3, init="propagated", random_state=0
    ).fit(X)
    assert model.labels_.shape == y.shape
    assert matched_frame_accuracy(model.labels_, y)[0] > 0.85
    segs = model.segments_
    assert segs[0][0] == 0 and segs[-1][1] == len(y)
    assert all(a[1] == b[0] for a, b in zip(segs[:-1], segs[1:], strict=True))
    for s, e, lab in segs:  # segments mapped back to frames carry their frames' label
        assert np.all(model.labels_[s:e] == lab)


def test_explicit_init_with_reduction_and_errors():
    X, y = _blocks(np.random.default_rng(3), [0, 1, 2], 2)
    truth_segments = [(0, 80, 0), (80, 160, 1), (160, 240, 2)]
    model = ACAEngine(
        3, 30, 80, n_init=1, k_reduce=12, reduce_cap=3, init=truth_segments, random_state=0
    ).fit(X)
    assert model.labels_.shape == (240,)
    with pytest.raises(ParameterError, match="distinct labels"):
        ACAEngine(2, 30, 80, n_init=1, init=truth_segments).fit(X)
    with pytest.raises(ParameterError, match="tile"):
        ACAEngine(3, 30, 80, n_init=1, init=[(0, 100, 0)]).fit(X)


def test_haca_on_blocks():
    X, y = _blocks(np.random.default_rng(1), [0, 1, 2, 1, 0], 3)
    accs = []
    for seed in range(3):
        model = HACAEngine(
            3,
            40,
            120,
            fine_clusters=6,
            fine_min_len_frames=8,
            fine_max_len_frames=20,
            n_init=5,
            random_state=seed,
        ).fit(X)
        accs.append(matched_frame_accuracy(model.labels_, y)[0])
    # a single run can stop in a local minimum of the fine level; most runs are near perfect
    assert np.median(accs) > 0.95 and min(accs) > 0.8
    fine = model.fine_segments_
    assert fine[0][0] == 0 and fine[-1][1] == len(y)
    assert all(a[1] == b[0] for a, b in zip(fine[:-1], fine[1:], strict=True))


def test_match_labels_hungarian_and_fresh_ids():
    new = np.array([0, 0, 0, 1, 1, 2])
    old = np.array([5, 5, 5, 3, 3, 3])
    m = match_labels(new, old, used={3, 5, 9})
    assert m[0] == 5 and m[1] == 3
    assert m[2] not in {3, 5, 9}  # unmatched: a fresh id, not one the listener already saw


def test_relabel_window_keeps_ids_consistent_and_absolute():
    X, _ = _blocks(np.random.default_rng(2), [0, 1, 2, 0, 1, 2], 2)
    cfg = ACAConfig(n_clusters=3, min_len_s=0.3, max_len_s=0.8, k_reduce=None, n_init=3)
    fps = 100.0
    first = relabel_window(X[:320], start_frame=1000, fps=fps, config=cfg)
    assert first.start == 1000 and first.end == 1320
    assert first.segments[0][0] == 1000 and first.segments[-1][1] == 1320
    second = relabel_window(X[160:480], start_frame=1160, fps=fps, config=cfg, previous=first)
    a = first.frame_labels()[160:]
    b = second.frame_labels()[:160]
    # the ids agree on the overlap as well as the best one-to-one renaming could make them
    assert np.mean(a == b) == pytest.approx(matched_frame_accuracy(b, a)[0])
    assert np.mean(a == b) > 0.5
    with pytest.raises(ParameterError, match="fps"):
        relabel_window(X, start_frame=0, fps=0, config=cfg)


def test_relabel_window_runs_in_a_worker_thread():
    from concurrent.futures import ThreadPoolExecutor

    X, _ = _blocks(np.random.default_rng(4), [0, 1, 2], 2)
    cfg = ACAConfig(n_clusters=3, min_len_s=0.3, max_len_s=0.8, k_reduce=None, n_init=2)
    direct = relabel_window(X, start_frame=0, fps=100.0, config=cfg)
    with ThreadPoolExecutor(1) as pool:
        threaded = pool.submit(relabel_window, X, start_frame=0, fps=100.0, config=cfg).result()
    assert threaded == direct  # same seed, same answer, whichever thread runs it


def test_window_segmentation_is_frozen_and_warmup_runs():
    w = WindowSegmentation(0, 4, [(0, 2, 1), (2, 4, 0)])
    np.testing.assert_array_equal(w.frame_labels(), [1, 1, 0, 0])
    with pytest.raises(AttributeError):
        w.start = 3
    warmup()


def test_aca_config_validation():
    with pytest.raises(ParameterError, match="max_len"):
        ACAConfig(min_len_s=2.0, max_len_s=1.0)
    with pytest.raises(ParameterError, match="kernel"):
        ACAConfig(kernel="rbf")


def test_match_labels_gives_fresh_ids_to_clusters_outside_the_overlap():
    from streamseg.offline.relabel import match_labels

    # new ids 0 and 1 overlap old 5 and 3; new id 2 only appears after the overlap
    mapping = match_labels([0, 0, 1, 1], [5, 5, 3, 3], used={3, 5}, new_ids=[0, 1, 2])
    assert mapping[0] == 5 and mapping[1] == 3
    assert mapping[2] not in (3, 5)


def test_relabel_window_with_a_cluster_born_after_the_overlap():
    from streamseg.config import ACAConfig
    from streamseg.offline.relabel import WindowSegmentation, relabel_window

    rng = np.random.default_rng(0)
    block = [np.full((30, 2), v) for v in ([0, 0], [5, 0], [0, 0], [5, 0], [0, 5], [0, 5])]
    X = np.concatenate(block) + rng.normal(0, 0.05, (180, 2))
    previous = WindowSegmentation(0, 120, [(0, 30, 7), (30, 60, 4), (60, 90, 7), (90, 120, 4)])
    config = ACAConfig(n_clusters=3, min_len_s=10, max_len_s=30, k_reduce=None, n_init=5)
    out = relabel_window(X[60:], start_frame=60, fps=1.0, config=config, previous=previous)
    labels = out.frame_labels()
    assert labels[0] == 7 and labels[45] == 4  # matched over frames 60-119
    assert labels[-1] not in (4, 7)  # the new cluster gets a fresh id


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_lloyd_kernel_equals_naive_twin(seed):
    from streamseg._kernels.kmeans import lloyd
    from tests.naive import naive_lloyd

    rng = np.random.default_rng(seed)
    X = np.concatenate([rng.normal(m, 0.5, (40, 3)) for m in (0, 3, 6)])
    start = X[rng.choice(len(X), 5, replace=False)].copy()
    want_labels, want_centres = naive_lloyd(X, start, 100)
    centres = start.copy()
    got = lloyd(X, centres, 100)
    np.testing.assert_array_equal(got, want_labels, err_msg=f"seed {seed}")
    np.testing.assert_allclose(centres, want_centres, rtol=1e-12, atol=1e-12)
    assert set(got) == set(range(5))  # no empty cluster


def test_lloyd_reseeds_an_empty_cluster():
    from streamseg._kernels.kmeans import lloyd
    from tests.naive import naive_lloyd

    X = np.array([[0.0], [0.1], [0.2], [10.0]])
    start = np.array([[0.1], [50.0], [100.0]])  # clusters 1 and 2 start empty
    got = lloyd(X, start.copy(), 10)
    np.testing.assert_array_equal(got, naive_lloyd(X, start, 10)[0])
    assert set(got) == {0, 1, 2}


def test_estimators_share_one_convention():
    """fps checked at construction, NotFittedError before fit, copies out, fit_each results
    independent of the model and of each other."""
    import copy

    from streamseg.exceptions import NotFittedError
    from streamseg.offline import ACA, HACA, ACASegmenter, LOFSegmenter, RepetitionSegmenter

    for cls in (ACA, HACA, ACASegmenter, LOFSegmenter, RepetitionSegmenter):
        for bad in (0, -1, float("nan")):
            with pytest.raises(ParameterError, match="fps"):
                cls(fps=bad)
        with pytest.raises(NotFittedError):
            cls().predict()
    X = np.repeat(np.eye(3), 60, axis=0) + np.random.default_rng(0).normal(0, 0.01, (180, 3))
    seg = ACASegmenter(fps=30.0).fit(X)
    labels = seg.labels_
    labels[:] = -7
    assert (seg.labels_ != -7).all()  # a copy
    with pytest.raises(AttributeError, match="no fitted attribute"):
        _ = seg.cuts_  # fitted, but not an attribute this estimator has
    model = HACAEngine(
        3,
        20,
        60,
        fine_clusters=4,
        fine_min_len_frames=5,
        fine_max_len_frames=15,
        n_init=2,
        random_state=0,
    ).fit(X)
    before = model.labels_
    fits = dict(model.fit_each(X, [2, 3]))
    assert len(set(fits[2].labels_.tolist())) == 2 and len(set(fits[3].labels_.tolist())) == 3
    assert (model.labels_ == before).all()  # fit_each left the fitted model alone
    twin = copy.copy(model)
    twin.labels_ = np.zeros(180, dtype=np.int64)
    assert (model.labels_ == before).all()


@pytest.mark.parametrize("name", ["ACA", "HACA"])
def test_aca_and_haca_take_a_config_and_fps_and_refuse_the_old_call(name):
    import streamseg.offline as offline
    from streamseg.offline.model_selection import model_from_config

    cls = getattr(offline, name)
    for old in ((3, 30, 80), (3,)):
        with pytest.raises(ParameterError, match=f"the old call: give {name}\\(ACAConfig"):
            cls(*old)
    with pytest.raises(ParameterError, match="the old call"):
        cls(ACAConfig(), 30.0, min_len_frames=30)
    X, y = _blocks(np.random.default_rng(2), [0, 1, 2, 1, 0], 3)
    cfg = ACAConfig(
        n_clusters=3,
        min_len_s=1.0,
        max_len_s=80 / 30,
        n_init=3,
        k_reduce=None,
        fine_min_len_s=8 / 30,
        fine_max_len_s=20 / 30,
        fine_clusters=6,
    )
    model = cls(cfg, fps=30.0).fit(X)
    # the engine built from the same config at the same rate gives the same segments
    engine = model_from_config(replace(cfg, hierarchical=name == "HACA"), 30.0).fit(X)
    assert model.segments_ == [tuple(int(v) for v in s) for s in engine.segments_]
    assert [tuple(s) for s in model.predict()] == model.segments_
    assert model.n_clusters_ == 3 and model.k_scores_ == {}
    assert matched_frame_accuracy(model.labels_, y)[0] > 0.9
    if name == "HACA":
        assert model.fine_segments_ == engine.fine_segments_
    else:
        assert model.restart_objectives_.shape == (3,)


@pytest.mark.parametrize("n_segments", [70, 90])  # 900-odd units (dense eigh), 1,100+ (ARPACK)
def test_propagated_first_restart_in_a_thread_gives_the_restarts_in_order(n_segments):
    """Threaded restarts draw restarts 1.. while the propagated restart 0 runs (its draws
    skipped ahead on a copy of the generator, then checked): the answer of n_jobs=1."""
    from streamseg.evaluation.synthetic import synthetic_sequence
    from streamseg.offline.dtak import frame_kernel

    x, _ = synthetic_sequence(n_segments, 0.0, np.random.default_rng(n_segments))
    K = frame_kernel(x, kernel="equality", binary_dtype=np.int8)
    classes = kmeans(x[:, None], 6, np.random.default_rng(0))
    fits = [
        ACAEngine(
            4,
            10,
            15,
            n_init=4,
            kernel="precomputed",
            init="propagated",
            random_state=3,
            n_jobs=jobs,
        ).fit(K, frame_classes=classes)
        for jobs in (1, 2)
    ]
    assert K.shape[0] ** 2 * 15 >= 10_000_000  # large enough to run in threads
    assert fits[0].segments_ == fits[1].segments_
    assert np.array_equal(fits[0].restart_objectives_, fits[1].restart_objectives_)
