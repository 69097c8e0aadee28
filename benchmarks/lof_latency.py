"""F1 against latency of the live cut detector: the decision delay, and two-stage decisions.

The decision delay ``delay_s`` is the knob that trades latency for evidence. This sweeps it,
every other default held, over the 14 recordings of sets cmu, cmu02 and hdm (``eval --all
data``'s), and prints per delay the mean F1 (label window + 0.5 s) of each set and the median
and maximum latency over every cut (from its frame to its emission). Then the two-stage
decision (``LOFConfig.early_delay_s``): per (early, confirming) delay, the mean F1 of the cuts
a listener sees first (provisional: every cut emitted, withdraws ignored) and of the final
cuts, how many pending cuts were withdrawn, and the latency of a final cut's first emission and
of its final decision. Last, the window, look-ahead and localisation together (the other
parts of the latency): mean F1 and latency on the two recordings a choice would be made on
(:data:`CHOSEN_ON`) and on the other twelve. ``--plot PNG`` draws the first two
(docs/img/lof_latency.png).

Run: .venv/bin/python benchmarks/lof_latency.py [--plot docs/img/lof_latency.png]  (~1 min)
"""

from __future__ import annotations

import argparse

import numpy as np
from _common import labelled, markdown_table

from streamseg.config import LOFConfig
from streamseg.evaluation.corpus import Prediction, score
from streamseg.offline.lof import lof_features
from streamseg.offline.lof_report import lof_report

DELAYS = (1.0, 1.2, 1.5, 1.8, 2.0, 2.5, 3.0)
#: (window_s, delay_s, refine_s): shorter windows, look-ahead and localisation, the other
#: parts of the latency (LOFStreamingSegmenter.latency_frames)
GEOMETRIES = (
    (1.75, 1.5, 0.8),
    (1.5, 1.2, 0.2),
    (1.25, 1.4, 0.2),
    (1.25, 1.2, 0.4),
    (1.25, 1.2, 0.3),
    (1.25, 1.2, 0.2),
    (1.25, 1.2, 0.1),
    (1.0, 1.2, 0.2),
    (1.25, 1.0, 0.2),
)
#: the geometry is chosen on these (the rest are held out)
CHOSEN_ON = ("86_01", "hdm_bd_0")
TWO_STAGE = ((0.8, 1.5), (1.2, 1.5), (1.2, 2.0))
SETS = ("cmu", "cmu02", "hdm")


def measure(items, config):
    """Mean F1 per set and over all, provisional F1, withdrawn share, latencies (s)."""
    f1 = {s: [] for s in SETS}
    prov, first, decided, n_withdrawn = [], [], [], 0
    for item in items:
        fps = item.recording.fps
        res = lof_report(lof_features(item.recording, config), fps, config, online=True)
        f1[item.group].append(score(item, Prediction(cuts=res["cuts"]), fps)["F1"])
        shown = sorted(res["cuts"] + res["withdrawn"])  # every cut a listener was shown
        prov.append(score(item, Prediction(cuts=shown), fps)["F1"])
        first += [x / fps for x in res["first_latency"]]
        decided += [x / fps for x in res["latency"]]
        n_withdrawn += len(res["withdrawn"])
    out = {s: float(np.mean(v)) for s, v in f1.items() if v}
    out["all"] = float(np.mean([x for v in f1.values() for x in v]))
    out.update(
        prov=float(np.mean(prov)),
        withdrawn=n_withdrawn,
        first=(np.median(first), np.max(first)),
        decided=(np.median(decided), np.max(decided)),
    )
    return out


def plot(sweep, two, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.2))
    lat = [m["decided"][0] for _, m in sweep]
    for s in SETS:
        ax.plot(lat, [m[s] for _, m in sweep], "o-", label=f"set {s}")
    for (d, m), x in zip(sweep, lat, strict=True):
        ax.annotate(
            f"{d:g} s",
            (x, m["hdm"]),
            textcoords="offset points",
            xytext=(0, 6),
            ha="center",
            fontsize=7,
        )
    ax.axvline(
        dict(zip([d for d, _ in sweep], lat, strict=True))[LOFConfig().delay_s],
        color="grey",
        ls=":",
        label=f"default delay {LOFConfig().delay_s:g} s",
    )
    ax.set(
        xlabel="median latency, s (point labels: decision delay)",
        ylabel="mean F1 (label window + 0.5 s)",
        ylim=(0, 1),
        title="Live cuts: F1 against latency",
    )
    ax.legend(fontsize=8)
    ax2.plot(lat, [m["all"] for _, m in sweep], "o-", color="grey", label="one stage")
    for i, (p, m) in enumerate(two):
        c = f"C{i}"
        ax2.plot([m["first"][0], m["decided"][0]], [m["prov"], m["all"]], "-", color=c, lw=0.8)
        ax2.plot(
            m["first"][0],
            m["prov"],
            "x",
            color=c,
            label=f"early {p[0]:g} / confirm {p[1]:g} s: first emission",
        )
        ax2.plot(
            m["decided"][0],
            m["all"],
            "o",
            color=c,
            mfc="none",
            label=f"early {p[0]:g} / confirm {p[1]:g} s: final",
        )
    ax2.set(
        xlabel="median latency, s",
        ylabel="mean F1, the 14 recordings",
        ylim=(0, 1),
        title="Two stages: pending cuts early, confirmed or withdrawn later",
    )
    ax2.legend(fontsize=6, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plot", metavar="PNG")
    args = ap.parse_args()
    items = labelled(SETS)
    sweep = [(d, measure(items, LOFConfig(delay_s=d))) for d in DELAYS]
    print(
        markdown_table(
            [
                "delay s",
                "F1 cmu",
                "F1 cmu02",
                "F1 hdm",
                "F1 all",
                "latency median s",
                "latency max s",
            ],
            [
                [
                    f"{d:g}" + (" (default)" if d == LOFConfig().delay_s else ""),
                    *(f"{m[s]:.3f}" for s in (*SETS, "all")),
                    f"{m['decided'][0]:.2f}",
                    f"{m['decided'][1]:.2f}",
                ]
                for d, m in sweep
            ],
        )
    )
    two = [(p, measure(items, LOFConfig(early_delay_s=p[0], delay_s=p[1]))) for p in TWO_STAGE]
    print()
    print(
        markdown_table(
            [
                "early / confirm s",
                "provisional F1",
                "final F1",
                "pending cuts withdrawn",
                "first emission med / max s",
                "final decision med / max s",
            ],
            [
                [
                    f"{p[0]:g} / {p[1]:g}",
                    f"{m['prov']:.3f}",
                    f"{m['all']:.3f}",
                    m["withdrawn"],
                    "{:.2f} / {:.2f}".format(*m["first"]),
                    "{:.2f} / {:.2f}".format(*m["decided"]),
                ]
                for p, m in two
            ],
        )
    )
    chosen = [i for i in items if i.name in CHOSEN_ON]
    rest = [i for i in items if i.name not in CHOSEN_ON]
    rows = []
    for w, d, r in GEOMETRIES:
        cfg = LOFConfig(window_s=w, delay_s=d, refine_s=r)
        a, b = measure(chosen, cfg), measure(rest, cfg)
        rows.append(
            [
                f"{w:g} / {d:g} / {r:g}" + (" (default)" if cfg == LOFConfig() else ""),
                f"{a['all']:.3f}",
                f"{a['decided'][0]:.2f}",
                f"{b['all']:.3f}",
                f"{b['decided'][0]:.2f}",
                f"{b['decided'][1]:.2f}",
            ]
        )
    print()
    print(
        markdown_table(
            [
                "window / delay / refine s",
                f"F1 chosen on ({', '.join(CHOSEN_ON)})",
                "latency median s",
                f"F1 the other {len(rest)}",
                "latency median s",
                "latency max s",
            ],
            rows,
        )
    )
    if args.plot:
        plot(sweep, two, args.plot)


if __name__ == "__main__":
    main()
