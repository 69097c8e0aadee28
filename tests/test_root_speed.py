"""Root-speed columns of the LOF features (``LOFConfig.root_speed_max``): hand-derived values,
causal (any packet sizes give the same columns), the teleport and NaN rules, and that the
detector's localisation and confirmations do not read them."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg.config import LOFConfig
from streamseg.daemon.algorithms import Algorithms
from streamseg.daemon.pipeline import StreamPipeline
from streamseg.exceptions import ParameterError
from streamseg.offline.lof import LOFSegmenter, lof_features
from streamseg.online.lof import StreamingLOFSegmenter
from streamseg.online.root_speed import RootSpeed, body_scale, root_speed_columns
from streamseg.skeleton.bones import bone_point_indices
from tests.naive import naive_root_speeds

FPS = 120.0
LAG = 12  # speed_lag_s 0.1 s at 120 Hz


def _still(rec, n):
    """``n`` copies of the recording's first pose."""
    return np.repeat(rec.positions[:1], n, axis=0).copy()


@pytest.mark.parametrize("case", ["walk", "nan", "teleport", "noisy"])
def test_kernel_equals_naive_twin(rec, case):
    pos = rec.positions[:300].copy()
    if case == "nan":
        pos[[0, 40, 41, 200], 3] = np.nan  # a limb joint: no body scale in those frames
        pos[100, 0] = np.nan  # the root
    elif case == "teleport":
        pos[150:] += np.array([3.0, 0.0, 0.0])
    elif case == "noisy":
        pos = pos + np.random.default_rng(2).normal(0, 0.01, pos.shape)
    cfg = LOFConfig(root_speed_max=2.0)
    b = bone_point_indices(rec.skeleton)
    want = naive_root_speeds(
        pos, b[0, 0], b[1:], np.array([0.0, 1.0, 0.0]), FPS, LAG, 2.0, cfg.root_jump / FPS
    )
    got = root_speed_columns(pos, rec.skeleton, FPS, cfg)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)
    assert np.array_equal(np.isnan(got), np.isnan(want))


def test_hand_values_walking_and_rising(rec):
    """A pose carried at 0.5 m/s along x (horizontal for up = y) and 0.2 m/s up: after
    ``lag`` frames the columns are pi * min(v / scale / root_speed_max, 1)."""
    n = 200
    pos = _still(rec, n)
    t = np.arange(n) / FPS
    pos[:, :, 0] += 0.5 * t[:, None]
    pos[:, :, 1] += 0.2 * t[:, None]
    scale = float(body_scale(rec.positions[:1], bone_point_indices(rec.skeleton))[0])
    cfg = LOFConfig(root_speed_max=4.0)
    got = root_speed_columns(pos, rec.skeleton, FPS, cfg)
    want = np.pi * np.minimum(np.array([0.5, 0.2]) / scale / 4.0, 1.0)
    np.testing.assert_allclose(got[LAG:], np.tile(want, (n - LAG, 1)), rtol=1e-9)
    # the first frames sum the steps there are (frame 0 has none) over the whole lag
    np.testing.assert_allclose(got[5], want * 5 / LAG, rtol=1e-9)
    assert (got[0] == 0).all()
    # clipped at pi above root_speed_max
    fast = root_speed_columns(pos, rec.skeleton, FPS, LOFConfig(root_speed_max=0.1))
    assert np.allclose(fast[LAG:], np.pi)


def test_scale_free_and_still(rec):
    """Positions in millimetres give the columns of metres; a still pose gives 0."""
    pos = _still(rec, 100)
    pos[:, :, 2] += 0.8 * np.arange(100)[:, None] / FPS
    a = root_speed_columns(pos, rec.skeleton, FPS)
    b = root_speed_columns(pos * 1000.0, rec.skeleton, FPS)
    np.testing.assert_allclose(a, b, rtol=1e-9)
    assert (root_speed_columns(_still(rec, 50), rec.skeleton, FPS) == 0).all()


def test_packets_do_not_change_the_columns(rec):
    pos = rec.positions[:1500].copy()
    pos[700:703] = np.nan
    whole = root_speed_columns(pos, rec.skeleton, FPS)
    rs = RootSpeed(LOFConfig(), FPS, rec.skeleton)
    rng = np.random.default_rng(3)
    parts, i = [], 0
    while i < len(pos):
        j = min(len(pos), i + int(rng.integers(1, 40)))
        parts.append(rs(pos[i:j]))
        i = j
    np.testing.assert_array_equal(np.vstack(parts), whole)
    # the NaN frames and the lag frames after them (their steps start or end at a NaN) only
    bad = np.flatnonzero(np.isnan(whole).any(axis=1))
    assert bad.tolist() == list(range(700, 703 + LAG))


def test_teleport_counts_as_no_motion(rec):
    pos = _still(rec, 100)
    pos[50:, :, 0] += 2.0  # 2 m in one frame (240 m/s): a re-centring, not a step
    got = root_speed_columns(pos, rec.skeleton, FPS)
    assert (got == 0).all()
    cfg = LOFConfig(root_jump=1e6)  # with no teleport rule the jump is a speed
    jumped = root_speed_columns(pos, rec.skeleton, FPS, cfg)
    assert (jumped[50 : 50 + LAG, 0] == np.pi).all() and (jumped[:, 1] == 0).all()


def test_reset_forgets_the_past(rec):
    pos = _still(rec, 40)
    rs = RootSpeed(LOFConfig(), FPS, rec.skeleton)
    rs(pos[:20])
    rs.reset()
    moved = pos[20:] + 5.0  # far from the last frame before the reset: no step across it
    assert (rs(moved) == 0).all()


def test_config_and_widths():
    cfg = LOFConfig()
    assert (cfg.root_columns, cfg.n_features, cfg.check_columns(cfg.n_features)) == (2, 19, 34)
    off = LOFConfig(root_speed_max=0)
    assert (off.root_columns, off.n_features, off.check_columns(17)) == (0, 17, 34)
    assert LOFConfig.paper().root_columns == 0
    for bad in (-1.0,):
        with pytest.raises(ParameterError, match="root_speed_max"):
            LOFConfig(root_speed_max=bad)
    with pytest.raises(ParameterError, match="root_jump"):
        LOFConfig(root_jump=0)
    with pytest.raises(ParameterError, match="root speeds"):
        StreamingLOFSegmenter(cfg, FPS, n_features=2)
    with pytest.raises(ParameterError, match="root-speed columns"):
        StreamingLOFSegmenter(cfg, FPS).learn_many(np.zeros((5, 17)))


def test_a_root_speed_change_alone_is_no_cut():
    """Two stationary pose columns and two root speeds that change once, at 20 s: the LOF
    sees it, but the cut's localisation and confirmations read the pose columns only, so no
    cut; fed as plain features (root_speed_max 0), the same 4 columns give a cut there."""
    rng = np.random.default_rng(5)
    n = int(40 * FPS)
    a = np.clip(1.5 + 0.3 * rng.standard_normal((n, 4)), 0, np.pi)
    a[:, 2:] = 0.2
    a[n // 2 :, 2:] = 2.5
    plain = LOFSegmenter(LOFConfig(root_speed_max=0), FPS, n_features=4).fit(a)
    assert plain.cuts_.size and np.abs(plain.cuts_ - n // 2).min() <= FPS
    root = LOFSegmenter(LOFConfig(), FPS, n_features=4).fit(a)
    np.testing.assert_array_equal(root.lof_, plain.lof_)  # the same histograms, reordered
    assert root.cuts_.size == 0


def test_streaming_equals_offline_with_root_speeds(rec):
    cfg = LOFConfig()
    a = lof_features(rec, cfg)
    assert a.shape == (rec.n_frames, 19)
    det = StreamingLOFSegmenter(cfg, FPS)
    ev = []
    for i in range(0, len(a), 97):
        ev += det.learn_many(a[i : i + 97])
    ev += det.finish()
    assert [e.frame for e in ev] == LOFSegmenter(cfg, FPS).fit(rec).cuts_.tolist()


def test_daemon_pipeline_feeds_the_detector_not_the_relabel_ring(rec):
    """The daemon's per-stream pipeline: the detector gets 19 columns (the same cuts as
    offline), the relabels' feature ring the 17 bone features."""
    pipe = StreamPipeline(rec.skeleton, FPS, Algorithms(), history=60.0)
    cuts = []
    for i in range(0, rec.n_frames, 120):
        cuts += [c[0] for c in pipe.push(rec.positions[i : i + 120], i)[0] if c[3] == "cut"]
    cuts += [c[0] for c in pipe._cuts(pipe.segmenter.finish()) if c[3] == "cut"]
    assert cuts == LOFSegmenter(LOFConfig(), FPS).fit(rec).cuts_.tolist()
    features, _frames = pipe.snapshot()
    assert features.shape[1] == 17 and pipe.segmenter.n_features == 19
