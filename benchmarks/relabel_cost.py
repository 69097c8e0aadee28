"""Cost of one relabel revision against the history it covers (median of 3 runs).

A revision of the daemon (``streamseg.daemon.pipeline.relabel``: HACA with the number of actions
found over K = 2..8 on one shared fine level, boundaries snapped to the live cuts, ids made
stream-wide) on the last H seconds of real 120 Hz features: CMU 86_01, 14_14 and 14_20
joined (115 s, the daemon's 17 cut features, float32 as the daemon keeps them). Beside it,
in the same run, the relabel the daemon made before the number of actions was found (ACA
with a fixed K = 4), as the baseline of the ratio. The interval each stream gets with many
streams is measured with the real daemon by
``benchmarks/daemon_throughput.py --skip-throughput --streams 10,100,1000 --seconds 70``.

Run: .venv/bin/python benchmarks/relabel_cost.py        (about a minute)
"""

from __future__ import annotations

import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from streamseg.config import ACAConfig  # noqa: E402
from streamseg.daemon.pipeline import Algorithms, relabel  # noqa: E402
from streamseg.io import read  # noqa: E402
from streamseg.offline.model_selection import fit_aca  # noqa: E402
from streamseg.skeleton import bone_angles  # noqa: E402

DATA = ROOT / "data"
FPS = 120.0
HISTORIES = (10, 20, 30, 60, 90)


def features():
    parts = [read(DATA / "cmu86/86_01.amc.gz", skeleton=DATA / "cmu86/86.asf")]
    parts += [read(DATA / f"cmu_exercise/{n}.amc.gz", skeleton=DATA / "cmu86/86.asf")
              for n in ("14_14", "14_20")]
    a = np.concatenate([bone_angles(r.positions, r.skeleton, inclinations=True)
                        for r in parts])
    return a.astype(np.float32).astype(np.float64)


def median_time(fn, runs=3):
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def main():
    X = features()
    algorithms = Algorithms()
    baseline = replace(ACAConfig(), n_clusters=4, hierarchical=False)
    fit_aca(X[:1200], ACAConfig(), FPS)  # compile
    print(f"{X.shape[0]} frames of features; ACA config {ACAConfig()}")
    print("| history s | frames | revision s (K found, HACA) | K found | fixed K = 4 ACA s "
          "(before) | ratio |")
    print("|---|---|---|---|---|---|")
    for h in HISTORIES:
        n = int(h * FPS)
        feats, frames = X[-n:], np.arange(n)
        t_new, res = median_time(lambda f=feats, fr=frames: relabel(algorithms, f, fr, FPS,
                                                                    None))
        t_old, _ = median_time(lambda f=feats: fit_aca(f, baseline, FPS))
        print(f"| {h} | {n} | {t_new:.3f} | {res.window.n_clusters} | {t_old:.3f} | "
              f"{t_new / t_old:.1f}x |", flush=True)


if __name__ == "__main__":
    main()
