"""A live packet in one kernel call (streamseg._kernels.stream_features): the same columns
as the kernels one by one and as their definitions, and the same cuts as the offline
computation on real recordings, whatever the packet size."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg._kernels.stream_features import lof_columns
from streamseg.config import LOFConfig
from streamseg.daemon.algorithms import Algorithms
from streamseg.daemon.pipeline import StreamPipeline
from streamseg.offline.lof import LOFSegmenter, lof_features
from streamseg.online.lof import StreamingLOFSegmenter
from streamseg.online.root_speed import NO_ROOT, RootSpeed
from streamseg.online.speed_features import SpeedColumns
from streamseg.recording import Recording
from streamseg.skeleton.bones import angles_at, bone_point_indices, up_vector
from tests.naive import naive_lof_columns

CONFIGS = {
    "default": LOFConfig(),
    "no root speeds": LOFConfig(root_speed_max=0),
    "no speeds": LOFConfig(speed_max=0, root_speed_max=0),
    "no inclinations": LOFConfig(inclinations=False, root_speed_max=0),
}


def _with_gaps(rec, n=600):
    pos = rec.positions[:n].copy()
    pos[[3, 40, 41, 42, n // 2], 5] = np.nan  # a limb joint: angles, scale and speeds undefined
    pos[100, 0] = np.nan  # the root
    return pos


def _fused_in_packets(pos, cfg, skeleton, fps, sizes):
    alg = Algorithms(lof_config=cfg)
    plan = alg.prepare(skeleton)
    seg = StreamingLOFSegmenter(cfg, fps)
    root = alg.root_speed(fps, skeleton)
    out, a, k = [], 0, 0
    while a < len(pos):
        b = min(a + sizes[k % len(sizes)], len(pos))
        _, cols, ok = lof_columns(
            np.ascontiguousarray(pos[a:b]),
            plan[2],
            NO_ROOT if root is None else root.kernel_args(),
            seg._speed_args(),
        )
        out.append(cols)
        a, k = b, k + 1
    return np.concatenate(out)


@pytest.mark.parametrize("name", CONFIGS)
def test_fused_columns_equal_the_kernels_one_by_one(rec, name):
    cfg = CONFIGS[name]
    pos = _with_gaps(rec)
    got = _fused_in_packets(pos, cfg, rec.skeleton, rec.fps, [1, 7, 120, 33])
    up = up_vector(rec.skeleton.up) if cfg.inclinations else None
    feats = angles_at(pos, bone_point_indices(rec.skeleton), up)
    if cfg.root_columns:
        feats = np.column_stack([feats, RootSpeed(cfg, rec.fps, rec.skeleton)(pos)])
    want = SpeedColumns(cfg, rec.fps, feats.shape[1])(feats) if cfg.speed_max > 0 else feats
    assert got.shape == want.shape
    assert np.array_equal(got, want, equal_nan=True)


@pytest.mark.parametrize("name", ["default", "no inclinations"])
def test_fused_columns_equal_the_naive_twin(rec, name):
    cfg = CONFIGS[name]
    pos = _with_gaps(rec, 240)
    got = _fused_in_packets(pos, cfg, rec.skeleton, rec.fps, [5, 120])
    points = bone_point_indices(rec.skeleton)
    g = cfg.frames(rec.fps)
    root = None
    if cfg.root_columns:
        root = (points[0, 0], points[1:], cfg.root_speed_max, cfg.root_jump / rec.fps)
    want = naive_lof_columns(
        pos,
        points.tolist(),
        up_vector(rec.skeleton.up) if cfg.inclinations else None,
        rec.fps,
        g["speed_lag"],
        cfg.speed_max,
        root,
    )
    assert np.array_equal(np.isnan(got), np.isnan(want))
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)


@pytest.fixture(scope="module")
def recordings(data_dir):
    """Real CMU takes: 86_01 (walk, jump, punch, kick) and two of subject 02."""
    from streamseg.io import read

    return [
        read(data_dir / "cmu86" / "86_01.amc.gz", skeleton=data_dir / "cmu86" / "86.asf"),
        *(
            read(data_dir / "cmu02" / f"{t}.amc.gz", skeleton=data_dir / "cmu02" / "02.asf")
            for t in ("02_01", "02_05")
        ),
    ]


@pytest.mark.parametrize("packet", [1, 7, 120])
def test_live_cuts_are_the_offline_cuts_on_real_recordings(recordings, packet):
    """The daemon's per-stream pipeline (one kernel call per packet) cuts real takes,
    repeated twice so the buffer evicts, where the offline segmenter cuts the same frames:
    same frames, decision frames and LOF scores."""
    cfg = LOFConfig()
    n_cuts = 0
    for rec in recordings:
        pos = np.concatenate([rec.positions] * 2)
        if packet == 1:
            pos = pos[:3000]
        p = StreamPipeline(rec.skeleton, rec.fps, Algorithms(lof_config=cfg), 60.0)
        live = []
        for a in range(0, len(pos), packet):
            live += p.push(pos[a : a + packet], a)[0]
        live += p.finish()
        off = LOFSegmenter(cfg, rec.fps).fit(
            lof_features(Recording(rec.fps, rec.skeleton, pos), cfg)
        )
        assert [c[0] for c in live] == list(off.cuts_)
        assert [c[2] for c in live] == list(off.decided_at_)
        assert [c[1] for c in live] == list(off.scores_)
        n_cuts += len(live)
    assert n_cuts >= 5  # decisions to compare, not a quality floor
