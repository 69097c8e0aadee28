"""ACA on the paper's synthetic setting (Zhou et al. 2008, section 5.1) against n, and the cost
of one live relabel revision.

Synthetic: 4 classes, segments of 10-15 frames, no noise, equality kernel, lengths 10..15,
10 random restarts on every core (``n_jobs=-1``; the result does not depend on it); seconds
per fit (median of 3; 1 at 10,000 frames), the exponent of a power law fitted to the four
sizes, the frame accuracy at 4,609 frames (must stay >= 0.99) and the speed-up over the
authors' Octave code on this machine at that size (102 s). Revision: what a stream's relabel
costs the worker, the daemon's own ``relabel`` (HACA, K found in 2..8, boundaries snapped,
ids made stream-wide) on the last 60 s of real features (86_01, 14_14, 14_20 joined).
"""

from __future__ import annotations

import numpy as np

from ._harness import DATA, median_time

SIZES = [1000, 2000, 4609, 10000]
OCTAVE_S = 102.0  # the authors' code under Octave on this machine, 4,609 frames


def _fit(n_segments):
    from streamseg.evaluation.metrics import matched_frame_accuracy
    from streamseg.evaluation.synthetic import synthetic_sequence
    from streamseg.offline.aca import ACAEngine

    x, truth = synthetic_sequence(n_segments, 0.0, np.random.default_rng(n_segments))
    model = ACAEngine(4, 10, 15, n_init=10, kernel="equality", random_state=0, n_jobs=-1)
    return x, lambda: model.fit(x), lambda: matched_frame_accuracy(model.labels_, truth)[0]


class Synthetic:
    params = SIZES
    param_names = ["frames"]
    timeout = 900
    number = repeat = rounds = 1

    def setup_cache(self):
        from streamseg.offline.aca import ACAEngine

        ACAEngine(2, 2, 3, n_init=1, kernel="equality").fit(np.arange(12.0) % 3)  # kernels loaded
        out = {}
        for n in SIZES:
            x, fit, accuracy = _fit(int(round(n / 12.5)))
            out[n] = {
                "frames": len(x),
                "seconds": median_time(fit, 1 if n > 5000 else 3),
                "accuracy": accuracy(),
            }
        return out

    def track_seconds(self, cache, n):
        return cache[n]["seconds"]

    track_seconds.unit = "s"

    def track_exponent(self, cache, n):
        if n != SIZES[-1]:
            return float("nan")  # one figure for the four sizes
        f = np.log([cache[m]["frames"] for m in SIZES])
        s = np.log([cache[m]["seconds"] for m in SIZES])
        return float(np.polyfit(f, s, 1)[0])

    track_exponent.unit = "power of n"

    def track_error(self, cache, n):
        return 1.0 - cache[n]["accuracy"]

    track_error.unit = "1 - accuracy"

    def track_speedup_over_octave(self, cache, n):
        return OCTAVE_S / cache[n]["seconds"] if n == 4609 else float("nan")

    track_speedup_over_octave.unit = "x Octave"


class Revision:
    timeout = 600
    number = repeat = rounds = 1

    def setup_cache(self):
        from streamseg.config import ACAConfig
        from streamseg.daemon.algorithms import Algorithms
        from streamseg.daemon.relabel_job import relabel
        from streamseg.io import read
        from streamseg.offline.model_selection import fit_aca
        from streamseg.skeleton import bone_angles

        asf = DATA / "cmu86" / "86.asf"
        parts = [read(DATA / "cmu86" / "86_01.amc.gz", skeleton=asf)]
        parts += [
            read(DATA / "cmu_exercise" / f"{n}.amc.gz", skeleton=asf) for n in ("14_14", "14_20")
        ]
        X = (
            np.concatenate([bone_angles(r.positions, r.skeleton, inclinations=True) for r in parts])
            .astype(np.float32)
            .astype(np.float64)
        )
        fit_aca(X[:1200], ACAConfig(), 120.0)  # kernels loaded
        feats = X[-7200:]
        frames = np.arange(feats.shape[0])
        algorithms = Algorithms()
        return median_time(lambda: relabel(algorithms, feats, frames, 120.0, None), 5)

    def track_60s_window_seconds(self, seconds):
        return seconds

    track_60s_window_seconds.unit = "s"
