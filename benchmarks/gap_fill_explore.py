"""Exploration (leaves the tree after decisions.md cites it): the gap-fill length.

Usage: python benchmarks/gap_fill_explore.py

On the three labelled CMU takes (86_01, 14_14, 14_20), every joint loses its positions in
random gaps of length L (one gap per joint per 4 s on average, the same seeds for every rule);
each gap is then either filled by interpolation (`fill`) or left for the detector to skip
(`skip`). Prints the mean cut F1 (label window + 0.5 s) of the offline LOF per L and rule,
and the clean F1.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from streamseg.config import LOFConfig
from streamseg.evaluation.labels import cut_windows, read_labels, true_cuts
from streamseg.evaluation.metrics import cut_scores
from streamseg.io import read
from streamseg.io.gaps import fill_gaps
from streamseg.offline.lof import position_features
from streamseg.offline.lof_report import lof_report

DATA = Path(__file__).resolve().parents[1] / "data"


def f1(rec, pos, segs):
    cfg = LOFConfig()
    cuts = lof_report(position_features(pos, rec.skeleton, rec.fps, cfg), rec.fps, cfg,
                      False)["cuts"]
    truth = true_cuts(segs, rec.n_frames)
    return cut_scores(cuts, truth, windows=cut_windows(segs)[:len(truth)],
                      margin=int(0.5 * rec.fps))["f1"]


def main():
    takes = [("86_01", DATA / "cmu86/86_01.amc.gz", DATA / "cmu86/labels_86_01.csv")]
    takes += [(n, DATA / f"cmu_exercise/{n}.amc.gz", DATA / "cmu_exercise/labels.csv")
              for n in ("14_14", "14_20")]
    rows = {}
    for name, path, labels in takes:
        rec = read(path, skeleton=DATA / "cmu86/86.asf")
        segs = read_labels(labels, name)
        rows.setdefault("clean", []).append(f1(rec, rec.positions, segs))
        for seconds in (0.1, 0.25, 0.5, 1.0):
            n = int(round(seconds * rec.fps))
            rng = np.random.default_rng(1)
            holes = rec.positions.copy()
            for j in range(holes.shape[1]):
                for a in rng.integers(0, rec.n_frames - n, rec.n_frames // int(4 * rec.fps)):
                    holes[a:a + n, j] = np.nan
            filled, _ = fill_gaps(holes, rec.fps, seconds)
            rows.setdefault(f"{seconds:g} s fill", []).append(f1(rec, filled, segs))
            rows.setdefault(f"{seconds:g} s skip", []).append(f1(rec, holes, segs))
    for key, vals in rows.items():
        print(f"{key:<12} mean F1 {np.mean(vals):.3f}  " + " ".join(f"{v:.3f}" for v in vals))


if __name__ == "__main__":
    main()
