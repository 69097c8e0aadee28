"""F1 against latency of the live cut detector: how long to wait before deciding.

The decision delay ``delay_s`` is the one knob that trades latency for evidence: a window is
judged once ``delay_s`` of data after it exist. This sweeps it with every other default held
(chosen on 86_01 and hdm_bd_0, ``benchmarks/lof_variants.py`` part 5) over every labelled
recording of ``benchmarks/lof_accuracy.py`` (CMU 86_01, 14_14, 14_20; the two CMU 02 joins;
the nine HDM05 joins, whose cuts are abrupt joins of clips), and prints, per delay, the mean
F1 (label window + 0.5 s) of each set and the median and maximum latency (frames at 120 Hz,
from a cut's frame to the frame that made the detector emit it). With ``--plot PNG`` it draws
the curve, one line per set (docs/img/lof_latency.png).

The two-stage decision (``LOFConfig.early_delay_s``, ``benchmarks/lof_two_stage.py``) adds
points a user can choose between: for each (early, confirming) delay of
``lof_two_stage.GRID``, the mean F1 over all recordings of the cuts a listener sees first
(provisional F1: every cut emitted, withdraws ignored) at the median latency of a final cut's
first emission, and of the final cuts (after withdraws, the one-stage F1 at the confirming
delay) at the median latency of the final decision; the picture's second panel draws them
beside the one-stage curve (mean over all recordings).

Run: .venv/bin/python benchmarks/lof_latency.py [--plot docs/img/lof_latency.png]  (~1 min)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from lof_accuracy import FPS, features, lof_cuts, recordings, score, set_of  # noqa: E402
from lof_two_stage import GRID, config_of  # noqa: E402
from lof_two_stage import run as two_stage_run  # noqa: E402

from streamseg.config import LOFConfig  # noqa: E402
from streamseg.evaluation.datasets import CMU02_MULTI_ACTION_SEQUENCES  # noqa: E402

DELAYS = (1.0, 1.2, 1.5, 1.8, 2.0, 2.5, 3.0)
SETS = ("cmu", "cmu02", "hdm")


def sweep(recs):
    rows = []
    for delay in DELAYS:
        cfg = LOFConfig(delay_s=delay)
        f1 = {s: [] for s in SETS}
        lats = []
        for name, (a, truth, windows) in recs.items():
            cuts, lat = lof_cuts(a, cfg, True)
            f1[set_of(name)].append(score(cuts, truth, windows, len(a))["f1"])
            lats += lat
        means = {s: float(np.mean(v)) for s, v in f1.items()}
        means["all"] = float(np.mean([x for v in f1.values() for x in v]))
        rows.append((delay, means,
                     float(np.median(lats)) if lats else float("nan"),
                     float(np.max(lats)) if lats else float("nan")))
    return rows


def plot(rows, two, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.2))
    lat = [r[2] / FPS for r in rows]
    for s in SETS:
        ax.plot(lat, [r[1][s] for r in rows], "o-", label=s)
    for r, x in zip(rows, lat):
        ax.annotate(f"{r[0]:g} s", (x, r[1]["hdm"]), textcoords="offset points", xytext=(0, 6),
                    ha="center", fontsize=7)
    d = LOFConfig().delay_s
    ax.axvline([x for r, x in zip(rows, lat) if r[0] == d][0], color="grey", ls=":",
               label=f"default delay {d:g} s")
    ax.set_xlabel("median latency, s (labels: decision delay)")
    ax.set_ylabel("mean F1 (label window + 0.5 s)")
    ax.set_ylim(0, 1)
    ax.set_title("Live cuts: F1 against latency (HDM05 and CMU 02 joins are abrupt)")
    ax.legend(fontsize=8)
    ax2.plot(lat, [r[1]["all"] for r in rows], "o-", color="grey", label="one stage (delay)")
    for r, x in zip(rows, lat):
        ax2.annotate(f"{r[0]:g}", (x, r[1]["all"]), textcoords="offset points", xytext=(0, 6),
                     ha="center", fontsize=7, color="grey")
    for i, (p, s) in enumerate(two):
        c = f"C{i % 10}"
        ax2.plot([s["first_med"], s["dec_med"]], [s["prov"], s["final"]], "-", color=c, lw=0.8)
        ax2.plot(s["first_med"], s["prov"], "x", color=c,
                 label=f"early {p[0]:g} / confirm {p[1]:g} s")
        ax2.plot(s["dec_med"], s["final"], "o", color=c, mfc="none")
    ax2.set_xlabel("median latency, s (x: first emission, o: final decision)")
    ax2.set_ylabel("mean F1, all recordings (x: provisional, o: final)")
    ax2.set_ylim(0, 1)
    ax2.set_title("Two stages: pending cuts early, confirmed or withdrawn later")
    ax2.legend(fontsize=6, ncol=2, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--plot", metavar="PNG")
    args = ap.parse_args()
    t0 = time.perf_counter()
    recs = {name: (features(r, True), truth, windows)
            for name, (r, truth, windows) in recordings().items()
            if name not in CMU02_MULTI_ACTION_SEQUENCES}
    rows = sweep(recs)
    print("| delay s | F1 cmu | F1 cmu02 | F1 hdm | F1 all | latency median s | latency max s |")
    print("|---|---|---|---|---|---|---|")
    for delay, f1, med, mx in rows:
        tag = " (default)" if delay == LOFConfig().delay_s else ""
        print(f"| {delay:g}{tag} | {f1['cmu']:.3f} | {f1['cmu02']:.3f} | {f1['hdm']:.3f} | "
              f"{f1['all']:.3f} | {med / FPS:.2f} | {mx / FPS:.2f} |")
    two = [(p, two_stage_run(recs, config_of(p))) for p in GRID]
    print("\ntwo stages (all recordings; F1 means; latency medians / maxima in s):")
    print("| early / confirm s | provisional F1 | final F1 | withdrawn | first emission | "
          "final decision |")
    print("|---|---|---|---|---|---|")
    for p, s in two:
        print(f"| {p[0]:g} / {p[1]:g} | {s['prov']:.3f} | {s['final']:.3f} | "
              f"{s['withdrawn']:.2f} of {s['n_pending']} | {s['first_med']:.2f} / "
              f"{s['first_max']:.2f} | {s['dec_med']:.2f} / {s['dec_max']:.2f} |")
    if args.plot:
        plot(rows, two, args.plot)
    print(f"[{time.perf_counter() - t0:.0f} s]")


if __name__ == "__main__":
    main()
