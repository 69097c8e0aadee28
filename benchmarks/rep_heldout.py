"""One candidate change against the defaults, on the actors held out from the choice.

The protocol of issue 14: a change is chosen on one actor (``--choose-on``) and then scored
once on the others, on several draws of sequences, clean and Kinect-like. This prints, for
the defaults and for the candidate (``--set FIELD=VALUE``, repeatable), the mean alpha (eq.
15), the share of exact counts and the mean |count error| of every held-out actor and of all
of them pooled, per draw and pooled over the draws, and the same for the choosing actor. No
per-class rows: the held-out actors are for scoring, not for looking. With ``--clips``, the
share of single HDM05 clips (one repetition or one action: truth not repetitive) that each
config calls repetitive, per actor.

With ``--choose-on none`` the choice was made on other draws of every actor (issue 14, round
9: chosen on draws 0-5 of bd, bk and dg): every actor is held out on the draws given (10-13,
drawn by no earlier round), pooled and per actor.

Sequences and the UKF cache are those of ``benchmarks/repetitions.py`` (``rep_data.py``).

Run: ``nice -n 5 .venv/bin/python benchmarks/rep_heldout.py --choose-on bk --seeds 0,1
--set max_subharmonic=1.0 [--clips]``.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np
from rep_data import features, load_clips, make_sequences, parse_set

from streamseg.config import RepetitionConfig
from streamseg.evaluation.datasets import HDM05_ACTORS, HDM05_REPETITIVE
from streamseg.evaluation.metrics import count_error, repetition_accuracy
from streamseg.offline.repetition import RepetitionSegmenter


def _row(rows):
    r = np.array(rows)
    return f"{r[:, 0].mean():6.3f} {np.mean(r[:, 1] == 0):5.2f} {np.abs(r[:, 1]).mean():5.2f}"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--choose-on", default="bk", choices=(*HDM05_ACTORS, "none"),
                    help="the actor chosen on, or none (chosen on other draws of every actor)")
    ap.add_argument("--seeds", default="0,1")
    ap.add_argument("--per-pair", type=int, default=3)
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE")
    ap.add_argument("--clips", action="store_true", help="single clips: false 'repetitive'")
    args = ap.parse_args(argv)
    base = RepetitionConfig()
    cand = replace(base, **parse_set(args.set, base))
    configs = (("defaults", base), ("candidate", cand))
    seeds = [int(x) for x in args.seeds.split(",")]
    clips, names = load_clips()
    t0 = time.perf_counter()
    res = []  # (seed, actor, cond, config name, (alpha, count error))
    for seed in seeds:
        for s in make_sequences(clips, names, args.per_pair, seed,
                                classes=set(HDM05_REPETITIVE)):
            for name, cfg in configs:
                seg = RepetitionSegmenter(cfg, s["fps"]).fit(features(s, cfg))
                res.append((seed, s["actor"], s["cond"], name,
                            (repetition_accuracy(seg.repetitions_, s["reps"]),
                             count_error(seg.count_, len(s["reps"])))))
    held = [a for a in HDM05_ACTORS if a != args.choose_on]
    who = (f"chosen on {args.choose_on}; held out {', '.join(held)}" if args.choose_on != "none"
           else f"no actor held back (chosen on other draws); scored {', '.join(held)}")
    print(f"{who}; seeds {seeds}; candidate "
          f"{parse_set(args.set, base)} ({time.perf_counter() - t0:.0f} s, UKF cached)")
    print(f"{'condition':9s} {'seeds':7s} {'actors':14s} | {'defaults: alpha':>15s} {'exact':>5s} "
          f"{'MAE':>5s} | {'candidate: alpha':>16s} {'exact':>5s} {'MAE':>5s} | {'n':>3s}")
    pooled = "held-out " if args.choose_on != "none" else "all "
    groups = [(pooled + "+".join(held), set(held))] + [(f"  {a}", {a}) for a in held]
    if args.choose_on != "none":
        groups.append((f"{args.choose_on} (chosen on)", {args.choose_on}))
    for cond in ("clean", "kinect"):
        for sd in [[x] for x in seeds] + ([seeds] if len(seeds) > 1 else []):
            for label, acts in groups:
                cells = []
                for name, _ in configs:
                    rows = [r for s_, a, c, nm, r in res
                            if s_ in sd and a in acts and c == cond and nm == name]
                    cells.append(_row(rows))
                n = len(rows)
                sdl = ",".join(map(str, sd))
                print(f"{cond:9s} {sdl:7s} {label:14s} | {cells[0]:>27s} | {cells[1]:>28s} | "
                      f"{n:3d}")
    if args.clips:
        run_clips(configs, seeds[0])


def run_clips(configs, seed):
    """Single clips (as ``repetitions.py --clips``): the share each config calls repetitive."""
    from rep_data import features, single_clips

    out = {}
    for row, kind, cond, seq, fps in single_clips(seed, configs[0][1]):
        for name, cfg in configs:
            rep = RepetitionSegmenter(cfg, fps).fit(features(seq, cfg)).repetitive_
            out.setdefault((cond, row["actor"], kind), {}).setdefault(name, []).append(rep)
    print("\nsingle clips (truth: not repetitive), share counted repetitive")
    print(f"{'condition':9s} {'actor':5s} {'clip':10s} {'n':>3s} "
          + " ".join(f"{name:>10s}" for name, _ in configs))
    for key in sorted(out):
        v = out[key]
        print(f"{key[0]:9s} {key[1]:5s} {key[2]:10s} {len(v['defaults']):3d} "
              + " ".join(f"{np.mean(v[name]):10.2f}" for name, _ in configs))


if __name__ == "__main__":
    main()
