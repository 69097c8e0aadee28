"""Angular-speed columns of the LOF features (``LOFConfig.speed_max``): kernel == naive twin,
causal (any packet sizes give the same columns), and what the segmenters histogram."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg.config import LOFConfig
from streamseg.exceptions import ParameterError
from streamseg.offline.lof import LOFSegmenter
from streamseg.online.lof import StreamingLOFSegmenter
from streamseg.online.speed_features import SpeedColumns, lof_columns
from tests.naive import naive_speed_columns

FPS = 120.0


def _walk(seed, n=700, d=5):
    rng = np.random.default_rng(seed)
    return np.clip(1.5 + np.cumsum(rng.normal(0, 0.03, (n, d)), axis=0), 0, np.pi)


@pytest.mark.parametrize("nan_rows", [(), (0, 1), (5, 30, 31, 32, 33, 400), tuple(range(20))])
def test_kernel_equals_naive_twin(nan_rows):
    a = _walk(len(nan_rows))
    a[list(nan_rows), 2] = np.nan  # one NaN makes the whole frame invalid
    cfg = LOFConfig(speed_max=1.5, speed_lag_s=0.1)
    got = lof_columns(a, cfg, FPS)
    want = naive_speed_columns(a, 12, 1.5, FPS, n_root=cfg.root_columns)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    speeds = got[:, [3, 4, 5, 8, 9]]  # the last 2 of the 5 are root speeds: after theirs
    assert np.isnan(speeds[list(nan_rows)]).all() if nan_rows else np.isfinite(got).all()
    assert np.nanmax(speeds) <= np.pi and np.nanmin(speeds) >= 0
    off = LOFConfig(speed_max=1.5, speed_lag_s=0.1, root_speed_max=0)
    np.testing.assert_allclose(
        lof_columns(a, off, FPS), naive_speed_columns(a, 12, 1.5, FPS), rtol=0, atol=1e-12
    )


def test_packets_do_not_change_the_columns():
    a = _walk(7)
    a[100:104] = np.nan
    cfg = LOFConfig()
    cols = SpeedColumns(cfg, FPS, a.shape[1])
    parts = [cols(a[i : i + 1]) for i in range(3)]  # single frames
    rest = [cols(a[i : i + 37]) for i in range(3, 700, 37)]  # then ragged packets
    np.testing.assert_array_equal(np.vstack(parts + rest), lof_columns(a, cfg, FPS))


def test_speed_saturates_at_speed_max():
    t = np.arange(240)[:, None] / FPS
    a = np.hstack([1.0 + 0.5 * t, 1.0 + 4.0 * t])  # 0.5 and 4 rad/s
    out = lof_columns(a, LOFConfig(speed_max=2.0), FPS)
    np.testing.assert_allclose(out[12:, 2], np.pi * 0.25, atol=1e-9)  # a quarter of 2 rad/s
    np.testing.assert_allclose(out[12:, 3], np.pi)  # above speed_max: the last bin


def test_segmenters_histogram_features_and_speeds():
    a = _walk(3, n=900, d=LOFConfig().n_features)
    on = StreamingLOFSegmenter(LOFConfig(), FPS)
    on.learn_many(a)
    assert on.buffer_vectors().shape[1] == 2 * a.shape[1] * LOFConfig().bins
    off = LOFSegmenter(LOFConfig(), FPS).fit(a)
    assert off.counts_.shape[1] == on.buffer_vectors().shape[1]
    # the paper's features are the angles alone
    paper = StreamingLOFSegmenter(LOFConfig.paper(), FPS)
    paper.learn_many(a[:, :8])
    assert paper.buffer_vectors().shape[1] == 8 * 10


def test_bad_speed_settings_are_refused():
    with pytest.raises(ParameterError, match="speed_max"):
        LOFConfig(speed_max=-1.0)
    with pytest.raises(ParameterError, match="speed_lag_s"):
        LOFConfig(speed_lag_s=0.0)
