"""Repetition segmentation on real HDM05 repetitions and CMU exercise routines.

Sequences: 3-8 real HDM05 single-repetition clips of one actor and one class concatenated in
take order (subsets drawn with a fixed seed); the true repetition boundaries are the joins.
dg has only two rotateArmsBothBackward clips, so its sequences repeat clips (drawn with
replacement). "Kinect-like": every 4th frame (120 -> 30 Hz) plus Gaussian noise of 2.5 cm on
every coordinate (positions are in metres, see ``Skeleton.units``). Parameters are the
RepetitionConfig defaults, fixed for every file (not tuned per file).

Also prints the count found in every labelled exercise block of CMU 14_14 and 14_20 (no
repetition ground truth exists there; the counts are for inspection).

Run: ``.venv/bin/python benchmarks/repetitions.py [--per-pair 3] [--seed 0]``
"""

from __future__ import annotations

import argparse
import csv
import time
from collections import defaultdict
from dataclasses import replace
from pathlib import Path

import numpy as np

from streamseg.config import RepetitionConfig
from streamseg.evaluation.metrics import count_error, repetition_accuracy
from streamseg.io import read
from streamseg.offline.repetition import RepetitionSegmenter
from streamseg.recording import Recording, Skeleton

DATA = Path(__file__).resolve().parents[1] / "data"
KINECT_FPS_STEP = 4  # 120 Hz -> 30 Hz
KINECT_NOISE_M = 0.025


def load_clips():
    """{(class, actor): [positions (n, J, 3), ...]} and the joint names, from clips.csv."""
    clips, names = defaultdict(list), {}
    with open(DATA / "hdm05_reps" / "clips.csv", newline="") as fh:
        for row in csv.DictReader(fh):
            path = DATA / "hdm05_reps" / row["class"] / (row["file"] + ".gz")
            asf = DATA / "hdm05_reps" / "asf" / f"HDM_{row['actor']}.asf"
            rec = read(path, skeleton=asf)
            assert rec.skeleton.units == "m", rec.skeleton.units
            clips[(row["class"], row["actor"])].append(rec.positions)
            names[row["actor"]] = rec.skeleton.names
    return clips, names


def make_sequences(clips, per_pair, seed):
    """[(class, actor, positions, true_repetitions)] with 3..8 clips each."""
    rng = np.random.default_rng(seed)
    out = []
    for (cls, actor), group in sorted(clips.items()):
        for _ in range(per_pair):
            k = int(rng.integers(3, 9))
            if len(group) >= k:
                idx = np.sort(rng.choice(len(group), size=k, replace=False))
            else:
                idx = rng.choice(len(group), size=k, replace=True)
            parts = [group[i] for i in idx]
            bounds = np.cumsum([0] + [p.shape[0] for p in parts])
            reps = [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]
            out.append((cls, actor, np.concatenate(parts), reps))
    return out


def kinectify(pos, reps, rng):
    """30 Hz and 2.5 cm noise; repetition boundaries mapped to the new frame numbers."""
    sub = pos[::KINECT_FPS_STEP]
    sub = sub + rng.normal(0.0, KINECT_NOISE_M, sub.shape)
    n = sub.shape[0]

    def m(f):
        return min(n, int(np.ceil(f / KINECT_FPS_STEP)))

    return sub, [(m(a), m(b)) for a, b in reps]


def run_hdm05(per_pair, seed, cfg):
    clips, names = load_clips()
    seqs = make_sequences(clips, per_pair, seed)
    rng = np.random.default_rng(seed + 1)
    rows, seconds = defaultdict(list), []
    for cls, actor, pos, reps in seqs:
        for cond in ("mocap 120Hz", "kinect-like 30Hz"):
            if cond.startswith("kinect"):
                p, r, fps = (*kinectify(pos, reps, rng), 120.0 / KINECT_FPS_STEP)
            else:
                p, r, fps = pos, reps, 120.0
            sk = Skeleton(names[actor], np.zeros(len(names[actor]), int),
                          np.zeros((len(names[actor]), 3)), "m")
            t0 = time.perf_counter()
            seg = RepetitionSegmenter(cfg).fit(Recording(fps, sk, p))
            seconds.append((time.perf_counter() - t0) / (p.shape[0] / fps))
            # baseline (the paper's ablation, Fig. 9): no parameter selection (theta = 1)
            base = RepetitionSegmenter(replace(cfg, power_ratio=1.0)).fit(seg.angles_, fps)
            res = []
            for s in (seg, base):
                res += [repetition_accuracy(s.repetitions_, r), count_error(s.count_, len(r))]
            rows[(cond, cls)].append(res)
            rows[(cond, "ALL")].append(res)
    print(f"HDM05: {len(seqs)} sequences x 2 conditions ({per_pair} per actor and class)")
    print("alpha: eq. 15; exact: share of sequences with the right count; MAE: mean |count "
          "error|; base_*: same without parameter selection (theta = 1, the paper's ablation)")
    print(f"{'condition':18s} {'class':28s} {'n':>3s} {'alpha':>6s} {'exact':>6s} {'MAE':>5s}"
          f" {'base_a':>6s} {'base_ex':>7s} {'base_MAE':>8s} {'a/base':>6s}")
    for (cond, cls), v in sorted(rows.items(), key=lambda kv: (kv[0][0], kv[0][1] == "ALL",
                                                                kv[0][1])):
        v = np.array(v)
        a, e, ba, be = v[:, 0], v[:, 1], v[:, 2], v[:, 3]
        print(f"{cond:18s} {cls[:28]:28s} {len(v):3d} {a.mean():6.3f} {np.mean(e == 0):6.2f} "
              f"{np.abs(e).mean():5.2f} {ba.mean():6.3f} {np.mean(be == 0):7.2f} "
              f"{np.abs(be).mean():8.2f} {a.mean() / ba.mean():6.2f}")
    print(f"compute: median {np.median(seconds):.3f} s per second of motion "
          f"(UKF + segmentation, one core)")


def run_cmu(cfg):
    asf = DATA / "cmu86" / "86.asf"
    blocks = defaultdict(list)
    with open(DATA / "cmu_exercise" / "labels.csv", newline="") as fh:
        for row in csv.DictReader(fh):
            blocks[row["sequence"]].append((int(row["start_frame"]) - 1, int(row["end_frame"]),
                                            row["action_label"]))
    print("\nCMU exercise routines (skeleton 86.asf as approximation): count per block")
    print(f"{'seq':6s} {'block':18s} {'frames':>11s} {'count':>5s} {'rep/s':>6s}")
    for seq, bl in sorted(blocks.items()):
        rec = read(DATA / "cmu_exercise" / f"{seq}.amc.gz", skeleton=asf)
        for a, b, label in bl:
            seg = RepetitionSegmenter(cfg).fit(rec.slice(a, min(b, rec.n_frames)))
            print(f"{seq:6s} {label:18s} {a:5d}-{b:5d} {seg.count_:5d} "
                  f"{seg.primary_frequency_hz_:6.2f}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-pair", type=int, default=3, help="sequences per actor and class")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--skip-cmu", action="store_true")
    args = ap.parse_args(argv)
    cfg = RepetitionConfig()
    run_hdm05(args.per_pair, args.seed, cfg)
    if not args.skip_cmu:
        run_cmu(cfg)


if __name__ == "__main__":
    main()
