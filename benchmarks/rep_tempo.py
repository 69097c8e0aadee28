"""Why one period does not fit some HDM05 sets: the tempo spread of the clips (issue 14).

The repetition segmenter (Wang et al.) reads one period off the spectrum and re-cuts the set
with a DTW template (``benchmarks/rep_diagnosis.py --counts``): both assume the repetitions of
a set are alike in length. The benchmark sets are HDM05 one-repetition clips concatenated
(``rep_data.py``), and the clips of one class and actor can differ a lot in length. This
prints, per repetitive class and actor:

- the clips' lengths (frames at 120 Hz): min / median / max and max / min;
- for the front kicks, the kick itself: from the first to the last frame with the left toes
  more than 10 cm above their lowest height in the clip; min / median / max of its length,
  and of the standing around it (clip - kick);
- for the hops, the number of vertical bounces of the root in each clip (local maxima of
  the root height at least 5 cm above the clip's lowest frame, 0.15 s apart): a hop with a
  preparatory bounce shows 2;
- on draws 0-5 of the benchmark sequences, the share whose spectral primary frequency
  (eq. 9, ``repetition_steps.primary_frequency``) lies within 0.75 cycles of the true count,
  clean and Kinect-like.

Run: ``nice -n 5 .venv/bin/python benchmarks/rep_tempo.py [--seeds 0,1,2,3,4,5]`` (UKF output
cached in ``.bench_cache/``; a cold cache takes about 15 min).
"""

from __future__ import annotations

import argparse
from collections import defaultdict

import numpy as np
from rep_data import features, load_clips, make_sequences

from streamseg.config import RepetitionConfig
from streamseg.evaluation.datasets import HDM05_REPETITIVE
from streamseg.offline import repetition_steps as steps

FPS = 120.0
UP = 1  # HDM05 (Acclaim) positions: y is up


def kick_span(pos: np.ndarray, toes: int, up: int, above_m: float = 0.10) -> int:
    """Frames from the first to the last one with the kicking foot's toes more than
    ``above_m`` above their lowest height in the clip (the kick itself)."""
    h = pos[:, toes, up] - pos[:, toes, up].min()
    on = np.flatnonzero(h > above_m)
    return int(on[-1] - on[0] + 1) if on.size else 0


def bounces(pos: np.ndarray, up: int) -> int:
    """Local maxima of the root height >= 5 cm above its minimum, at least 0.15 s apart."""
    h = pos[:, 0, up] - pos[:, 0, up].min()
    gap = int(0.15 * FPS)
    peaks = [t for t in range(1, h.size - 1)
             if h[t] >= 0.05 and h[t] == h[max(0, t - gap):t + gap + 1].max()]
    return len(peaks)


def spectral_hits(seeds, cfg):
    """{(class, actor, condition): [primary cycles within 0.75 of the true count, ...]}."""
    clips, names = load_clips()
    out = defaultdict(list)
    for seed in seeds:
        for s in make_sequences(clips, names, 3, seed, classes=set(HDM05_REPETITIVE)):
            X = features(s, cfg)
            cycles, power = steps.power_spectrum(X, cfg.fft_pad)
            ip = steps.primary_frequency(cycles, power, min_cycles=cfg.min_cycles,
                                         max_cycles=cfg.max_frequency_hz * X.shape[0] / s["fps"])
            out[(s["cls"], s["actor"], s["cond"])].append(
                abs(float(cycles[ip]) - len(s["reps"])) <= 0.75)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0,1,2,3,4,5")
    args = ap.parse_args(argv)
    seeds = [int(x) for x in args.seeds.split(",")]
    cfg = RepetitionConfig()
    clips, names = load_clips()
    hits = spectral_hits(seeds, cfg)
    print(f"HDM05 one-repetition clips per class and actor; spectral period on draws {seeds}")
    print(f"{'class':28s} {'actor':5s} {'n':>2s} | {'clip frames min/med/max':>23s} "
          f"{'ratio':>5s} | {'kick min/med/max':>16s} | {'standing min/med/max':>20s} | "
          f"{'bounces':>7s} | {'period ok clean':>15s} {'kinect':>6s}")
    for cls in HDM05_REPETITIVE:
        for actor in ("bd", "bk", "dg"):
            group = clips[(cls, actor)]
            n = np.array([p.shape[0] for p in group])
            kick = stand = bc = "-"
            if cls.startswith("kick"):
                k = np.array([kick_span(p, names[actor].index("ltoes"), UP) for p in group])
                kick = f"{k.min():4d} {int(np.median(k)):5d} {k.max():5d}"
                r = n - k
                stand = f"{r.min():6d} {int(np.median(r)):6d} {r.max():6d}"
            if cls.startswith("hop"):
                bc = ",".join(map(str, sorted({bounces(p, UP) for p in group})))
            c = np.mean(hits[(cls, actor, "clean")])
            k2 = np.mean(hits[(cls, actor, "kinect")])
            print(f"{cls[:28]:28s} {actor:5s} {len(group):2d} | {n.min():7d} "
                  f"{int(np.median(n)):7d} {n.max():7d} {n.max() / n.min():5.2f} | {kick:>16s} | "
                  f"{stand:>20s} | {bc:>7s} | {c:15.2f} {k2:6.2f}")


if __name__ == "__main__":
    main()
