"""ACA and HACA (with temporal reduction) on real motion capture: frame accuracy and time.

Features: ``streamseg.skeleton.quaternion_features`` (14 joints x 4 quaternion components,
as in the paper). Scoring: Hungarian-matched frame accuracy against the human labels, k = the
number of distinct labels of the recording. Parameters are the ``ACAConfig`` defaults, held
fixed for every recording: reduction into 20 k-means classes with runs capped at 1/6 s (the
paper's 20 frames at 120 Hz), segments 0.5-2 s (one to a few cycles of an action), HACA
primitives 1/12-1/4 s in 10 clusters, Gaussian kernel with the data-driven bandwidth, 10
restarts. They were chosen on CMU 86_01 only (by trying a handful of round values);
14_14 and 14_20 (CMU exercise routines, mocap6 labels, skeleton 86.asf as an approximation)
are held out. Several seeds per method show the spread of the random restarts. HACA-l is
HACA with the coarse kernel on primitive labels instead of DTAK (better on 86_01 where it
was tried first, worse on the held-out recordings, hence not the default).

Reference on 86_01: the authors' code gets 0.904 (ACA) and 0.966 (HACA) with hand-set
parameters per trial.

Run: ``.venv/bin/python benchmarks/aca_mocap.py [--seeds 5]``
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from streamseg.config import ACAConfig
from streamseg.evaluation.labels import frame_labels, read_labels
from streamseg.evaluation.metrics import matched_frame_accuracy
from streamseg.io import read
from streamseg.offline.model_selection import model_from_config
from streamseg.skeleton import quaternion_features

DATA = Path(__file__).resolve().parents[1] / "data"
RECORDINGS = [
    ("86_01", DATA / "cmu86/86_01.amc.gz", DATA / "cmu86/86.asf", DATA / "cmu86/labels_86_01.csv"),
    (
        "14_14",
        DATA / "cmu_exercise/14_14.amc.gz",
        DATA / "cmu86/86.asf",
        DATA / "cmu_exercise/labels.csv",
    ),
    (
        "14_20",
        DATA / "cmu_exercise/14_20.amc.gz",
        DATA / "cmu86/86.asf",
        DATA / "cmu_exercise/labels.csv",
    ),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args()
    model_from_config(ACAConfig(), 120.0).fit(np.random.default_rng(0).normal(size=(300, 4)))
    print(
        f"{'recording':>9} {'frames':>6} {'k':>2} {'method':>6} {'mean acc':>8} {'min acc':>8} "
        f"{'max acc':>8} {'median s':>8}"
    )
    for name, amc, asf, csv in RECORDINGS:
        rec = read(amc, asf)
        X = quaternion_features(rec)
        segs = read_labels(csv, name)
        truth = frame_labels(segs, rec.n_frames)
        keep = truth >= 0
        k = len({s.label for s in segs})
        for method, extra in (
            ("ACA", {"hierarchical": False}),
            ("HACA", {"hierarchical": True}),
            ("HACA-l", {"hierarchical": True, "coarse_kernel": "labels"}),
        ):
            accs, secs = [], []
            for seed in range(args.seeds):
                cfg = dataclasses.replace(ACAConfig(), n_clusters=k, random_state=seed, **extra)
                t0 = time.perf_counter()
                model = model_from_config(cfg, rec.fps).fit(X)
                secs.append(time.perf_counter() - t0)
                accs.append(matched_frame_accuracy(model.labels_[keep], truth[keep])[0])
            print(
                f"{name:>9} {rec.n_frames:6d} {k:2d} {method:>6} {np.mean(accs):8.3f} "
                f"{np.min(accs):8.3f} {np.max(accs):8.3f} {np.median(secs):8.2f}"
            )


if __name__ == "__main__":
    main()
