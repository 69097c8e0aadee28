"""Offline LOF pipeline: histograms, LOF (scikit-learn oracle), peaks, segmenter API."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from sklearn.neighbors import LocalOutlierFactor as sklearn_lof  # the test oracle

from streamseg._kernels.histogram import contrast_at, refine_cut, span_contrast
from streamseg._kernels.peaks import dp_keep, peak_windows
from streamseg.config import LOFConfig
from streamseg.exceptions import NotFittedError, ParameterError
from streamseg.offline.lof import (
    LOFSegmenter,
    frame_bins,
    lof_scores,
    normalized,
    window_histograms,
)
from tests.naive import (
    naive_contrast,
    naive_cosine_lof,
    naive_douglas_peucker,
    naive_peak_windows,
    naive_refine_cut,
    naive_span_contrast,
    naive_window_counts,
)


def _sk(x, k):
    return -sklearn_lof(n_neighbors=k, metric="cosine").fit(x).negative_outlier_factor_


def _clustered(rng, n=120, d=80):
    """Count-like vectors from three clusters plus a few bridge points."""
    centres = rng.integers(0, 30, (3, d)).astype(float)
    x = centres[rng.integers(0, 3, n)] + rng.integers(0, 6, (n, d))
    x[:5] = 0.5 * (centres[0] + centres[1]) + rng.integers(0, 3, (5, d))
    return x


@pytest.mark.parametrize("k", [1, 5, 20])
def test_lof_equals_sklearn_cosine(k):
    x = _clustered(np.random.default_rng(k))
    x = x / x.sum(axis=1, keepdims=True)
    np.testing.assert_allclose(lof_scores(x, k), _sk(x, k), rtol=1e-9)


def test_lof_k_larger_than_sample_uses_n_minus_1_like_sklearn():
    x = _clustered(np.random.default_rng(3), n=8)
    with pytest.warns(UserWarning):
        ref = _sk(x, 20)
    np.testing.assert_allclose(lof_scores(x, 20), ref, rtol=1e-9)


def test_held_pose_lof_finite_and_equal_to_sklearn():
    rng = np.random.default_rng(7)
    x = _clustered(rng, n=90)
    x[20:70] = x[20]  # a held pose: 50 identical windows, more than k
    ours = lof_scores(x, 10)
    assert np.isfinite(ours).all()
    np.testing.assert_array_equal(ours[21:69], 1.0)
    # With precomputed distances scikit-learn sees exactly our numbers: equal to rounding.
    u = x / np.linalg.norm(x, axis=1, keepdims=True)
    d = np.clip(1.0 - u @ u.T, 0.0, 2.0)
    d[20:70, 20:70] = 0.0
    np.fill_diagonal(d, 0.0)
    with pytest.warns(UserWarning):  # scikit-learn warns about the duplicates
        ref_pre = -sklearn_lof(n_neighbors=10, metric="precomputed").fit(d).negative_outlier_factor_
    np.testing.assert_allclose(ours, ref_pre, rtol=1e-9)
    # With metric="cosine" scikit-learn's BLAS gives identical rows distance ~3e-16, not 0;
    # through lrd = 1 / (d + 1e-10) that moves lrd (and LOF next to the pose) by d / 1e-10,
    # a few 1e-6 relative: the duplicate handling agrees, the last digits cannot.
    with pytest.warns(UserWarning):
        ref = _sk(x, 10)
    np.testing.assert_allclose(ours, ref, rtol=1e-5)


def test_lof_matches_naive_with_exclusion_zone():
    rng = np.random.default_rng(11)
    x = _clustered(rng, n=60)
    t = np.arange(60) * 5
    for excl in (0, 12, 40):
        np.testing.assert_allclose(
            lof_scores(x, 4, t, excl), naive_cosine_lof(x, 4, t, excl), rtol=1e-12
        )


def test_window_histograms_match_naive_and_skip_nan():
    rng = np.random.default_rng(2)
    a = rng.uniform(0, np.pi, (400, 8))
    a[[0, 50, 51, 399]] = np.pi  # the closed upper end goes to the last bin
    a[100:130, 3] = np.nan
    counts, centres, nv = window_histograms(a, 60, 7, 10, min_valid=1)
    ref, ref_nv = naive_window_counts(a, 60, 7, 10)
    np.testing.assert_array_equal(counts, ref)
    np.testing.assert_array_equal(nv, ref_nv)
    np.testing.assert_array_equal(centres, np.arange(len(ref)) * 7 + 30)
    assert nv.min() == 30  # windows over the NaN frames count only their valid frames


def test_window_histograms_drop_windows_with_too_few_valid_frames():
    a = np.random.default_rng(0).uniform(0, np.pi, (200, 8))
    a[40:100] = np.nan
    counts, centres, nv = window_histograms(a, 50, 10, 10, min_valid=25)
    assert (nv >= 25).all()
    assert not np.isin(centres, [65, 75, 85]).any()  # windows 40-90, 50-100: < 25 valid


@settings(max_examples=60, deadline=None)
@given(
    a=arrays(
        np.float64,
        st.tuples(st.integers(1, 80), st.just(8)),
        elements=st.one_of(st.floats(0, np.pi), st.just(np.nan)),
    ),
    window=st.integers(1, 30),
    step=st.integers(1, 10),
    bins=st.integers(2, 16),
)
def test_histogram_invariant_each_angle_sums_to_one(a, window, step, bins):
    step = min(step, window)
    counts, _, nv = window_histograms(a, window, step, bins, min_valid=1)
    h = normalized(counts, nv).reshape(len(counts), 8, bins)
    np.testing.assert_allclose(h.sum(axis=2), 1.0, rtol=1e-12)
    assert (h >= 0).all()


@settings(max_examples=80, deadline=None)
@given(y=arrays(np.float64, st.integers(3, 40), elements=st.floats(0, 10)), eps=st.floats(0, 3))
def test_douglas_peucker_matches_naive(y, eps):
    keep = np.zeros(len(y), dtype=np.uint8)
    stack = np.zeros(4 * len(y) + 4, dtype=np.int64)
    dp_keep(y, 0, len(y) - 1, eps, keep, stack)
    assert list(np.flatnonzero(keep)) == sorted(naive_douglas_peucker(y, eps))


@settings(max_examples=80, deadline=None)
@given(
    y=arrays(np.float64, st.integers(1, 60), elements=st.floats(0.5, 5)),
    delay=st.integers(1, 6),
    tol=st.floats(0, 0.5),
    mads=st.floats(0, 4),
    gap=st.integers(0, 8),
)
def test_peak_rule_matches_naive(y, delay, tol, mads, gap):
    got = list(peak_windows(y, delay, tol, mads, 1.0, gap))
    assert got == naive_peak_windows(y, delay, tol, mads, 1.0, gap)


def test_segmenter_finds_cuts_between_synthetic_actions():
    """Three 'actions' with different angle distributions: cuts near the two joins."""
    rng = np.random.default_rng(5)
    t = np.arange(1500)[:, None]
    d = LOFConfig().n_features
    parts = [
        np.clip(
            mu + 0.25 * np.sin(t / 9.0 + np.arange(d)) + rng.normal(0, 0.05, (1500, d)), 0, np.pi
        )
        for mu in (0.6, 1.6, 2.4)
    ]
    seg = LOFSegmenter(LOFConfig(), fps=120).fit(np.concatenate(parts))
    cuts = seg.cuts_
    assert len(cuts) == 2
    # predict(): the three segments between the cuts, tiling the frames
    segs = seg.predict()
    assert [(s.start, s.end) for s in segs] == [(0, cuts[0]), (cuts[0], cuts[1]), (cuts[1], 4500)]
    assert [s.label for s in segs] == [0, 1, 2]
    seg.cuts_[:] = -1  # a copy: the model keeps its cuts
    assert (seg.cuts_ == cuts).all()
    assert np.abs(cuts - np.array([1500, 3000])).max() <= seg.geometry["step"] * 2
    assert seg.lof_.shape == seg.centres_.shape
    assert seg.n_nan_frames_ == 0


def test_segmenter_validates_input():
    with pytest.raises(ParameterError, match="expected"):
        LOFSegmenter(LOFConfig(), 120).fit(np.zeros((100, 7)))
    with pytest.raises(ParameterError, match="inclinations=True"):
        LOFSegmenter(LOFConfig(), 120).fit(np.zeros((100, 8)))  # the paper's angles only
    with pytest.raises(NotFittedError, match="fit"):
        LOFSegmenter(LOFConfig(), 120).predict()
    with pytest.raises(NotFittedError, match="fit"):
        _ = LOFSegmenter(LOFConfig(), 120).cuts_
    assert not hasattr(LOFSegmenter(LOFConfig(), 120), "cuts_")


def test_config_validates_and_paper_preset():
    with pytest.raises(ParameterError, match="step_s"):
        LOFConfig(step_s=0)
    with pytest.raises(ParameterError, match="k="):
        LOFConfig(k=0)
    with pytest.raises(ParameterError, match="refine_s"):
        LOFConfig(refine_s=-0.1)
    with pytest.raises(ParameterError, match="inclinations"):
        LOFConfig(inclinations=1)
    assert (LOFConfig().n_features, LOFConfig.paper().n_features) == (19, 8)
    g = LOFConfig.paper().frames(120)
    assert (g["window"], g["step"], LOFConfig.paper().k) == (500, 45, 20)
    # seconds, so a 30 Hz stream keeps the durations (2 s: a whole number of frames at both)
    cfg = LOFConfig(window_s=2.0)
    assert cfg.frames(30)["window"] * 4 == cfg.frames(120)["window"]


def tie_angles(n):
    """Strategy: (n, 8) angles from four values and NaN; with few bins, ties (the earliest
    maximum wins) are common."""
    return arrays(
        np.float64,
        (n, 8),
        elements=st.one_of(st.sampled_from([0.1, 1.0, 2.0, 3.0]), st.just(np.nan)),
    )


def binned(a, bins):
    """The frame bins and validity of angles ``a`` (n, 8), and two scratch count vectors."""
    fb, valid = frame_bins(a, bins)
    return fb, valid, np.zeros(8 * bins, dtype=np.int64), np.zeros(8 * bins, dtype=np.int64)


def ring_of(fb, valid, size, lo, hi):
    """Frames ``lo .. hi - 1`` of ``fb``/``valid`` in a ring of ``size`` rows (frame ``f`` at
    ``f % size``), as the streaming detector keeps them."""
    ring, rv = np.zeros((size, 8), dtype=np.int8), np.zeros(size, dtype=np.uint8)
    for f in range(lo, hi):
        ring[f % size], rv[f % size] = fb[f], valid[f]
    return ring, rv


@settings(max_examples=80, deadline=None)
@given(
    data=st.data(),
    n=st.integers(4, 120),
    window=st.integers(1, 25),
    radius=st.integers(0, 30),
    bins=st.integers(2, 6),
)
def test_refine_cut_matches_naive_and_reads_a_ring_like_the_whole_array(
    data, n, window, radius, bins
):
    a = data.draw(tie_angles(n))
    centre = data.draw(st.integers(0, n))
    n_avail = data.draw(st.integers(0, n))
    first = data.draw(st.integers(-5, n))
    fb, valid, left, right = binned(a, bins)
    got = refine_cut(fb, valid, n, centre, radius, window, bins, n_avail, 0, first, left, right)
    assert got == naive_refine_cut(a, bins, centre, radius, window, n_avail, first)
    # the streaming detector keeps only the last `size` frames in a ring (frame g at g % size)
    size = data.draw(st.integers(window, max(window, n)))
    oldest = max(0, n_avail - size)
    ring, rv = ring_of(fb, valid, size, oldest, n_avail)
    assert refine_cut(
        ring, rv, size, centre, radius, window, bins, n_avail, oldest, first, left, right
    ) == refine_cut(fb, valid, n, centre, radius, window, bins, n_avail, oldest, first, left, right)


def test_refine_finds_an_abrupt_change_and_zero_radius_keeps_the_centre():
    rng = np.random.default_rng(9)
    a = np.concatenate([rng.uniform(0.2, 0.9, (300, 8)), rng.uniform(2.0, 2.9, (300, 8))])
    fb, valid = frame_bins(a, 10)
    left, right = np.zeros(80, dtype=np.int64), np.zeros(80, dtype=np.int64)
    # a change at 300: any centre within the radius is moved onto it
    for centre in (260, 300, 333):
        assert refine_cut(fb, valid, 600, centre, 48, 60, 10, 600, 0, 0, left, right) == 300
    # not enough frames after the candidates yet (n_avail): the centre stays
    assert refine_cut(fb, valid, 600, 300, 48, 60, 10, 300, 0, 0, left, right) == 300
    assert refine_cut(fb, valid, 600, 280, 0, 60, 10, 600, 0, 0, left, right) == 280
    # the previous cut's gap (first) bounds the search from below
    assert refine_cut(fb, valid, 600, 300, 48, 60, 10, 600, 0, 310, left, right) == 310
    # the centre rule: every cut is a window centre
    cfg = LOFConfig(refine_s=0.0, inclinations=False, root_speed_max=0)
    seg = LOFSegmenter(cfg, fps=120).fit(a)
    assert len(seg.cuts_) and np.isin(seg.cuts_, seg.centres_).all()
    assert LOFConfig.paper().refine_s == 0.0


@settings(max_examples=80, deadline=None)
@given(data=st.data(), n=st.integers(1, 120), window=st.integers(1, 25), bins=st.integers(2, 6))
def test_contrast_matches_naive_and_reads_a_ring_like_the_whole_array(data, n, window, bins):
    a = data.draw(tie_angles(n))
    g = data.draw(st.integers(0, n))
    n_avail = data.draw(st.integers(0, n))
    fb, valid, left, right = binned(a, bins)
    got = contrast_at(fb, valid, n, g, window, bins, n_avail, 0, left, right)
    assert got == pytest.approx(naive_contrast(a, bins, g, window, n_avail), abs=1e-12)
    size = data.draw(st.integers(max(1, 2 * window), max(2 * window, n)))
    oldest = max(0, n_avail - size)
    ring, rv = ring_of(fb, valid, size, oldest, n_avail)
    assert contrast_at(
        ring, rv, size, g, window, bins, n_avail, oldest, left, right
    ) == contrast_at(fb, valid, n, g, window, bins, n_avail, oldest, left, right)


@settings(max_examples=80, deadline=None)
@given(data=st.data(), n=st.integers(1, 120), bins=st.integers(2, 6))
def test_span_contrast_matches_naive_and_reads_a_ring_like_the_whole_array(data, n, bins):
    """The novelty check's statistic: sides of any length, as the naive twin computes them."""
    a = data.draw(tie_angles(n))
    hi = data.draw(st.integers(0, n))
    g = data.draw(st.integers(0, hi))
    lo = data.draw(st.integers(0, g))
    fb, valid, left, right = binned(a, bins)
    got = span_contrast(fb, valid, n, lo, g, hi, bins, left, right)
    assert got == pytest.approx(naive_span_contrast(a, bins, lo, g, hi), abs=1e-12)
    size = data.draw(st.integers(max(1, hi - lo), max(1, n)))
    ring, rv = ring_of(fb, valid, size, lo, hi)
    assert span_contrast(ring, rv, size, lo, g, hi, bins, left, right) == got


def test_contrast_hand_derived_values():
    """Two angles, 2 bins: [0.1, 0.1] x 10 then [3.0, 0.1] x 10."""
    a = np.array([[0.1] * 8] * 10 + [[3.0] + [0.1] * 7] * 10)
    fb, valid = frame_bins(a, 2)
    left, right = np.zeros(16, dtype=np.int64), np.zeros(16, dtype=np.int64)
    # at the change: counts (10, 0 | 10, 0 ...) vs (0, 10 | 10, 0 ...): cos = 7/8 of the norms
    assert contrast_at(fb, valid, 20, 10, 10, 2, 20, 0, left, right) == pytest.approx(1 / 8)
    # inside one half: identical histograms
    assert contrast_at(fb, valid, 20, 5, 5, 2, 20, 0, left, right) == 0.0
    # no frame on the right yet: undefined
    assert contrast_at(fb, valid, 20, 10, 10, 2, 10, 0, left, right) == -1.0
    # sides of any length: 5 frames of the first half against the 10 of the second (the same
    # 1/8); a segment of 10 + 5 frames against the last 5 (angle 0: (10, 5) . (0, 5))
    assert span_contrast(fb, valid, 20, 5, 10, 20, 2, left, right) == pytest.approx(1 / 8)
    assert span_contrast(fb, valid, 20, 0, 15, 20, 2, left, right) == pytest.approx(
        1 - (10 * 0 + 5 * 5 + 7 * 15 * 5) / np.sqrt((10**2 + 5**2 + 7 * 15**2) * (5**2 + 7 * 5**2))
    )
    assert span_contrast(fb, valid, 20, 10, 10, 20, 2, left, right) == -1.0
