"""Streaming LOF detector: API, NaN policy, bounded memory, and online == offline on 86_01."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg._kernels.lof import lof_batch
from streamseg._kernels.peaks import dominates, is_peak, robust_threshold
from streamseg.config import LOFConfig
from streamseg.exceptions import ParameterError
from streamseg.offline.lof import LOFSegmenter
from streamseg.online.events import CutEvent
from streamseg.online.lof import StreamingLOFSegmenter, warmup
from streamseg.online.speed_features import lof_columns
from tests.naive import naive_contrast, naive_refine_cut, naive_span_contrast

FAST = LOFConfig(window_s=0.5, step_s=0.1, k=5, buffer_s=6.0, delay_s=0.5)
D = LOFConfig().n_features  # 8 bone angles + 9 inclinations


def _actions(seed=0, n=600, levels=(0.6, 1.6, 2.4, 1.1)):
    rng = np.random.default_rng(seed)
    t = np.arange(n)[:, None]
    return np.concatenate(
        [
            np.clip(
                mu + 0.25 * np.sin(t / 7.0 + np.arange(D)) + rng.normal(0, 0.05, (n, D)), 0, np.pi
            )
            for mu in levels
        ]
    )


@pytest.fixture(scope="module")
def angles_86_01(data_dir):
    from streamseg import io
    from streamseg.offline.lof import lof_features

    rec = io.read(data_dir / "cmu86" / "86_01.amc.gz", skeleton=data_dir / "cmu86" / "86.asf")
    return lof_features(rec)  # the 17 bone features and the 2 root speeds


def test_learn_one_equals_learn_many():
    a = _actions(1)
    a[700:720] = np.nan
    one = StreamingLOFSegmenter(FAST, fps=100)
    ev1 = [c for row in a for c in one.learn_one(row)] + one.finish()
    many = StreamingLOFSegmenter(FAST, fps=100)
    ev2 = []
    for i in range(0, len(a), 37):  # ragged packets
        ev2 += many.learn_many(a[i : i + 37])
    ev2 += many.finish()
    assert ev1 == ev2 and len(ev1) >= 3
    np.testing.assert_array_equal(one.buffer_lof(), many.buffer_lof())
    assert all(isinstance(c, CutEvent) and c.provisional for c in ev1)


def test_cuts_emitted_once_with_stated_latency():
    a = _actions(2)
    s = StreamingLOFSegmenter(FAST, fps=100)
    cuts = s.learn_many(a)
    assert len(cuts) >= 3
    frames = [c.frame for c in cuts]
    assert len(set(frames)) == len(frames) and frames == sorted(frames)
    # without NaN drops every decision happens on the last frame of window w + delay, exactly
    # decision_lag frames after the peak window's centre; localisation moves the cut from
    # that centre by at most `refine` frames, so latency_frames() bounds every latency
    g = s.geometry
    assert all((c.emitted_at - (g["window"] - 1)) % g["step"] == 0 for c in cuts)
    centres = np.array([c.emitted_at - s.decision_lag_frames() for c in cuts])
    assert ((centres - g["window"] // 2) % g["step"] == 0).all()
    assert (np.abs(np.array(frames) - centres) <= g["refine"]).all()
    assert max(c.latency for c in cuts) <= s.latency_frames()
    assert s.latency_frames() == s.decision_lag_frames() + g["refine"]
    assert min(np.abs(np.array(frames)[:, None] - np.array([600, 1200, 1800])).min(axis=0)) <= 20


def test_nan_frames_are_skipped_and_counted():
    a = _actions(3)
    clean = StreamingLOFSegmenter(FAST, fps=100)
    clean.learn_many(a)
    b = a.copy()
    b[300:310] = np.nan  # 10 frames: every window over them keeps >= min_valid frames
    b[900, 4] = np.inf
    s = StreamingLOFSegmenter(FAST, fps=100)
    s.learn_many(b)
    assert s.n_nan_frames_ == 11
    assert s.n_dropped_windows_ == 0 and s.n_windows_ == clean.n_windows_
    assert np.isfinite(s.buffer_lof()).all()
    # histograms hold counts of valid frames only: each angle sums to the valid count
    v = s.buffer_vectors().reshape(-1, D, FAST.bins).sum(axis=2)
    assert (v == v[:, :1]).all() and v.max() <= s.geometry["window"]
    # a long dropout drops the windows it covers instead of poisoning them
    b[1000:1200] = np.nan
    s2 = StreamingLOFSegmenter(FAST, fps=100)
    s2.learn_many(b)
    assert s2.n_dropped_windows_ > 0 and np.isfinite(s2.buffer_lof()).all()


def test_held_pose_stream_stays_finite_and_quiet():
    a = np.tile(np.linspace(0.3, 2.8, D), (1500, 1))  # a statue
    s = StreamingLOFSegmenter(FAST, fps=100)
    assert s.learn_many(a) + s.finish() == []
    np.testing.assert_array_equal(s.buffer_lof(), 1.0)


def test_memory_bounded_and_views_never_mutate():
    s = StreamingLOFSegmenter(FAST, fps=100)
    cap = s.geometry["capacity"]
    nbytes = sum(v.nbytes for v in vars(s).values() if isinstance(v, np.ndarray))
    s.learn_many(_actions(4, n=1500))
    assert len(s.buffer_lof()) == cap
    assert sum(v.nbytes for v in vars(s).values() if isinstance(v, np.ndarray)) == nbytes
    before = {k: v.copy() for k, v in vars(s).items() if isinstance(v, np.ndarray)}
    s.buffer_lof()[:] = -1
    s.buffer_vectors()[:] = -1
    s.buffer_centres()[:] = -1
    _ = s.n_frames_, s.n_nan_frames_, s.latency_frames()
    for k, v in vars(s).items():
        if isinstance(v, np.ndarray):
            np.testing.assert_array_equal(v, before[k], err_msg=k)


def test_bad_input_raises():
    s = StreamingLOFSegmenter(FAST, fps=100)
    with pytest.raises(ParameterError, match=r"\(19,\)"):
        s.learn_one(np.zeros(8))
    with pytest.raises(ParameterError, match="n_frames, 19"):
        s.learn_many(np.zeros((5, 8)))
    paper = StreamingLOFSegmenter(LOFConfig(inclinations=False, root_speed_max=0), fps=100)
    with pytest.raises(ParameterError, match=r"n_frames, 8\).*LOFConfig\(inclinations=True\)"):
        paper.learn_many(np.zeros((5, 17)))
    for bad in (0, "8", 2.0, True):
        with pytest.raises(ParameterError, match="n_features"):
            StreamingLOFSegmenter(FAST, fps=100, n_features=bad)
    own = StreamingLOFSegmenter(FAST, fps=100, n_features=np.int64(3))
    assert own.learn_many(np.ones((10, 3))) == []
    with pytest.raises(ParameterError, match=r"expected \(n_frames, 3\)$"):
        own.learn_many(np.ones((10, 8)))
    with pytest.raises(ParameterError, match="fps"):
        StreamingLOFSegmenter(FAST, fps=0)
    for bad in (-0.1, 1.5):
        with pytest.raises(ParameterError, match="novelty"):
            LOFConfig(novelty=bad)


def test_warmup_and_cheap_creation():
    warmup()
    many = [StreamingLOFSegmenter(LOFConfig(), fps=120) for _ in range(50)]
    assert all(m.n_frames_ == 0 for m in many)


def test_finish_decides_each_window_once():
    a = _actions(5)
    s = StreamingLOFSegmenter(FAST, fps=100)
    ev = s.learn_many(a) + s.finish()
    assert s.finish() == []
    assert len({c.frame for c in ev}) == len(ev)


def test_online_lof_equals_offline_on_86_01(angles_86_01):
    """The whole recording (38 s) fits the default 75 s buffer: identical LOF values."""
    cfg = LOFConfig()
    s = StreamingLOFSegmenter(cfg, fps=120)
    s.learn_many(angles_86_01)
    off = LOFSegmenter(cfg, fps=120).fit(angles_86_01)
    np.testing.assert_array_equal(s.buffer_lof(), off.lof_)
    np.testing.assert_array_equal(s.buffer_vectors(), off.counts_)
    np.testing.assert_array_equal(s.buffer_centres(), off.centres_)


def _naive_replay(angles, cfg=None):
    """The live cuts of ``angles`` (shorter than the buffer) and their naive replay:
    (online, replay, peaks the contrast rejected, peaks the novelty check rejected)."""
    cfg = LOFConfig() if cfg is None else cfg
    s = StreamingLOFSegmenter(cfg, fps=120)
    online = [c.frame for c in s.learn_many(angles)]
    off = LOFSegmenter(cfg, fps=120).fit(angles)
    g = s.geometry
    delay, m = g["delay"], len(off.lof_)
    keep = np.zeros(2 * delay + 1, dtype=np.uint8)
    stack = np.zeros(8 * delay + 8, dtype=np.int64)
    replay, last, rejected, novel = [], -(1 << 40), 0, 0
    cols = lof_columns(angles, cfg, 120)  # what is histogrammed: features and speeds
    cols = cols[:, : cfg.check_columns(angles.shape[1])]  # what the checks read: no root speeds
    for w in range(m - delay):
        t = w + delay
        y = lof_batch(off.counts_[: t + 1], cfg.k, off.centres_[: t + 1], 0)[0]
        thr = max(cfg.min_score, robust_threshold(y, t + 1, cfg.threshold_mads, np.empty(t + 1)))
        lo = max(0, w - delay)
        if (
            y[w] >= thr
            and w - last >= g["min_gap"]
            and dominates(y, lo, t, w, g["min_gap"])
            and is_peak(y, lo, t, w, cfg.dp_tolerance, keep, stack)
        ):
            n_avail = int(off.centres_[t]) - g["window"] // 2 + g["window"]
            first = replay[-1] + g["min_gap"] * g["step"] if replay else 0
            cut = naive_refine_cut(
                cols, cfg.bins, int(off.centres_[w]), g["refine"], g["window"], n_avail, first
            )
            # the confirming two-sample contrast, with the frames seen at the decision
            since = replay[-1] if replay else 0  # the before side starts at the last cut
            if cfg.min_contrast > 0 and (
                n_avail - cut < g["window"]
                or naive_contrast(cols, cfg.bins, cut, g["contrast"], n_avail, since)
                < cfg.min_contrast
            ):
                rejected += 1
                continue
            # novelty: the whole current segment, as far back as the frame ring holds
            ring_old = max(0, n_avail - g["history"])
            if (
                naive_span_contrast(
                    cols, cfg.bins, max(since, ring_old), cut, min(cut + g["contrast"], n_avail)
                )
                < cfg.novelty
            ):
                novel += 1
                continue
            replay.append(cut)
            last = w
    return online, replay, rejected, novel


def test_online_decisions_replay_offline_on_buffer_contents(angles_86_01, data_dir):
    """Each streaming decision equals the offline LOF + peak rule on the windows it had.

    Window w is decided when window w + delay arrives, so its LOF is the offline LOF of the
    prefix of windows 0..w+delay, and its threshold uses that prefix's curve; the cut frame is
    localised with the frames up to the end of window w + delay and confirmed by the contrast
    of the frames before and after it seen by then, and by the novelty of the whole current
    segment (since the last cut, as far back as the frame ring holds) against the after side.
    Recomputing that offline (naive localisation, contrast and novelty) for every window
    reproduces the emitted cuts exactly on 86_01 and 14_14; the contrast rejects a peak on
    86_01, the novelty check one on 14_14 without the root speeds (a false cut at frame 4348,
    inside the twists; with them that peak is gone).
    """
    from streamseg import io

    online, replay, rejected, _ = _naive_replay(angles_86_01)
    assert online == replay and len(online) >= 5 and rejected >= 1
    rec = io.read(
        data_dir / "cmu_exercise" / "14_14.amc.gz", skeleton=data_dir / "cmu86" / "86.asf"
    )
    from streamseg.offline.lof import lof_features

    a = lof_features(rec)
    online, replay, _, _ = _naive_replay(a)
    assert online == replay and len(online) >= 5
    # without the root speeds 14_14's twists make a peak that only the novelty check rejects
    off = LOFConfig(root_speed_max=0)
    a = lof_features(rec, off)
    online, replay, _, novel = _naive_replay(a, off)
    assert online == replay and len(online) >= 5 and novel >= 1
    # the novelty check alone, cuts at window centres: the frame ring still holds its sides
    alone = LOFConfig(refine_s=0.0, min_contrast=0.0, root_speed_max=0)
    assert alone.frames(120)["history"] > alone.frames(120)["window"]
    online, replay, _, novel = _naive_replay(a, alone)
    assert online == replay and len(online) >= 5 and novel >= 1


def test_offline_cuts_are_the_live_decisions(angles_86_01):
    """One decision rule: offline segmentation makes the live detector's decisions over the
    file, whatever the packet size of the live feed."""
    cfg = LOFConfig()
    s = StreamingLOFSegmenter(cfg, fps=120)
    online = []
    for i in range(0, len(angles_86_01), 37):
        online += s.learn_many(angles_86_01[i : i + 37])
    online += s.finish()
    off = LOFSegmenter(cfg, fps=120).fit(angles_86_01)
    assert [c.frame for c in online] == list(off.cuts_)
    assert [c.emitted_at for c in online] == list(off.decided_at_)
    np.testing.assert_array_equal([c.score for c in online], off.scores_)


def test_short_and_empty_streams():
    s = StreamingLOFSegmenter(LOFConfig(), fps=120)
    assert s.learn_many(np.zeros((0, D))) == []
    assert s.learn_many(np.full((100, D), 1.0)) == []  # shorter than one window
    assert s.finish() == [] and s.n_windows_ == 0 and len(s.buffer_lof()) == 0


def test_same_seconds_at_30_and_120_hz():
    """Window, step and delay are in seconds: a stream decimated 4x cuts at the same times.

    A 2 s window is a whole number of frames at both rates (the default 2.25 s is not at 30
    Hz: 67.5 frames), so the two detectors see the same seconds exactly.
    """
    a = _actions(6, n=1800)
    cuts = {}
    cfg = LOFConfig(window_s=2.0)
    for fps, sub in ((120, 1), (30, 4)):
        s = StreamingLOFSegmenter(cfg, fps=fps)
        cuts[fps] = np.array([c.frame / fps for c in s.learn_many(a[::sub]) + s.finish()])
    assert len(cuts[120]) == len(cuts[30]) == 3
    np.testing.assert_allclose(cuts[30], cuts[120], atol=cfg.step_s)
