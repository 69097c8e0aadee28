"""The cut detector: the per-stream pipeline alone and the streaming LOF in steady state.

Pipeline: ``StreamPipeline.push`` (bone angles + inclinations, root speeds, angular speeds,
streaming LOF, the relabel ring) on 86_01 cycled to 60,000 frames in 120-frame packets, no
sockets: the algorithm's own limit for one stream (median of 3). Steady state: the detector
alone (``StreamingLOFSegmenter.learn_many``, 120-frame blocks of precomputed features) with
its 75 s buffer full, microseconds per frame (median of 3). Offline: ``LOFSegmenter`` on a
10,000-frame recording from joint positions (median of 5).
"""

from __future__ import annotations

import numpy as np

from ._harness import median_time, recording

N = 60_000
PACKET = 120


class Pipeline:
    timeout = 600
    number = repeat = rounds = 1

    def setup_cache(self):
        from streamseg.daemon.algorithms import Algorithms
        from streamseg.daemon.pipeline import StreamPipeline

        rec = recording()
        pos = rec.positions[np.arange(N) % rec.n_frames]

        def run():
            p = StreamPipeline(rec.skeleton, rec.fps, Algorithms(), 60.0)
            for a in range(0, N, PACKET):
                p.push(pos[a : a + PACKET], a)

        run()
        return N / median_time(run, 3)

    def track_frames_per_s(self, rate):
        return rate

    track_frames_per_s.unit = "frames/s"


class Detector:
    timeout = 600
    number = repeat = rounds = 1

    def setup_cache(self):
        from streamseg.config import LOFConfig
        from streamseg.offline.lof import LOFSegmenter, lof_features
        from streamseg.online.lof import StreamingLOFSegmenter

        rec = recording()
        cfg = LOFConfig()
        feats = lof_features(rec, cfg)
        X = feats[np.arange(N) % len(feats)]
        g = cfg.frames(rec.fps)
        full = (g["capacity"] + 2) * g["step"] + g["window"]  # frames until the buffer is full

        def steady():
            det = StreamingLOFSegmenter(cfg, rec.fps)
            det.learn_many(X[:full])
            import time

            t = time.perf_counter()
            for a in range(full, N, PACKET):
                det.learn_many(X[a : a + PACKET])
            return (time.perf_counter() - t) / (N - full)

        steady()
        us = sorted(steady() for _ in range(3))[1] * 1e6
        offline = median_time(lambda: LOFSegmenter(cfg, rec.fps).fit(rec), 5)
        return {"steady_us": us, "offline_s": offline}

    def track_steady_us_per_frame(self, cache):
        return cache["steady_us"]

    track_steady_us_per_frame.unit = "us/frame"

    def track_offline_4579_frames_s(self, cache):
        return cache["offline_s"]

    track_offline_4579_frames_s.unit = "s"
