"""Where the repetition segmenter loses alpha: a decomposition on HDM05 sequences.

alpha (Wang et al. eq. 15, ``streamseg.evaluation.metrics.repetition_accuracy``) pairs the
i-th found repetition with the i-th true one and averages ``1 - |length error| / true
length`` over the pairs; a sequence counted 0 scores 0. So ``1 - mean alpha`` over sequences
splits exactly into the terms of each sequence divided by its pair count and by the number of
sequences. This prints that split (in alpha points; the columns of a row sum to the loss):

1. per condition: sequences counted 0, sequences miscounted (the pairing then slips), and in
   exactly counted sequences the first, middle and last repetitions of the set;
2. per class: alpha and exact counts (``--aggregate`` leaves this out: for held-out actors);
3. the boundaries: alpha with the outer ends (start of the first, end of the last
   repetition) set to the truth, with the inner cuts set to the truth, and what the cut
   placement stages give (exactly counted sequences only): the spectral boundaries
   (``align="none"``), the DTW tiling alone (``align_snap=0``), tiling + snap (the
   defaults), and an oracle snap that puts each inner cut on the true join whenever the join
   lies inside the snap's window;
4. exactly counted sequences: the repetitions by the size of their length error (number,
   and their loss);
5. the signed length error (found - true) / true by position in the set.

With ``--counts`` (issue 14, round 9) the wrong counts instead: a table class x actor x
(over, under, exact), and for each wrongly counted sequence the stage that got it wrong and
why (:func:`count_cause`): rejected as not repetitive (which test), the spectral count
(``align="none"``: the primary frequency's cycles against the true count, i.e. the period
estimate, or the boundaries) or the DTW re-cut (the spectral count right and the tiling
changing it: pieces merging two true repetitions, or splitting one). With ``--objective``
also, for each wrongly counted sequence the re-cut ran on, the DTW tiling objective (the sum of
piece length x mean DTW cost against the template that cut the pieces) of the true tiling
against that of the pieces found: when the true one costs more, the objective itself prefers
the wrong count (no bound or search change can fix it); otherwise the search missed it.

Round 9 protocol (declared after the ``--counts`` diagnosis on draws 0-5 of bd, bk and dg,
before any other run of the mechanism; draws 10-13 drawn by no earlier round):

- Diagnosis and choice: draws 0-5 of all three actors (every actor was chosen on by an
  earlier round; what is fresh is the draws). 270 sequences per condition.
- Mechanism: ``RepetitionConfig.align_max_compress`` (most template frames per sequence
  frame in a DTW step; 2 = today). GRID {2, 3, 4}, each scored by ``benchmarks/
  rep_heldout.py --choose-on none --seeds 0,1,2,3,4,5 --set align_max_compress=V``. Chosen:
  the highest mean of the clean and Kinect-like alpha (pooled over the three actors); within
  0.001 of it the smaller value wins. If 2 is chosen, nothing is held out.
- Held out once: ``benchmarks/rep_heldout.py --choose-on none --seeds 10,11,12,13 --set
  align_max_compress=V`` (bd, bk and dg pooled, 180 sequences per condition).
- Adoption rule: the chosen value becomes the default only if, on draws 10-13 pooled, its
  alpha is higher than the defaults' clean AND Kinect-like, its share of exact counts is not
  lower in either, and ``tests/test_rep_eval_sets.py`` passes unmodified with it as the default.

Round 10 protocol (issue 14; declared 2026-12-02 14:53 UTC, after a look at the dg hop
sequences of draws 0 and 1 only, before any other run of the mechanism; draws 10-13 drawn
by no earlier round):

- Mechanism: ``RepetitionConfig.root_height_weight`` (0 = off, today): the pelvis height
  relative to its median, in body-scale units, times the weight, as a 31st analysed column
  (spectrum, selection, and always in the DTW template's features).
- Choice on draws 0-5 of bd, bk and dg (270 sequences per condition): GRID {1, 2, 4}, each by
  ``benchmarks/rep_heldout.py --choose-on none --seeds 0,1,2,3,4,5 --set
  root_height_weight=W``. Chosen: the highest mean of the clean and Kinect-like pooled alpha;
  within 0.001 of it the smaller weight wins. It goes on to the held-out run only if that
  mean beats the defaults' by more than 0.001 and its exact counts (pooled, clean and
  Kinect-like each) are not lower than the defaults'; otherwise nothing is held out.
- Held out once: ``benchmarks/rep_heldout.py --choose-on none --seeds 10,11,12,13 --set
  root_height_weight=W`` (180 sequences per condition).
- Adoption rule: W becomes the default only if on draws 10-13 pooled its alpha and its
  exact counts are not lower than the defaults', clean and Kinect-like; ``tests/
  test_rep_eval_sets.py`` passes unmodified with W as the default; and the routine figures
  (``benchmarks/repetitions.py --skip-hdm05 --routines --set root_height_weight=W`` against
  the same without ``--set``): HDM05 repetitive sets counted exactly and action takes
  counted 0 not lower.

Conditions: clean (120 Hz mocap), Kinect-like (30 Hz + 2.5 cm noise), and with
``--degradations`` each degradation alone: "30 Hz" (every 4th frame, no noise), "noise"
(120 Hz + 2.5 cm noise) and "clean@30" (the clean UKF output subsampled to 30 Hz: the
segmenter at 30 Hz without the UKF running at 30 Hz). The UKF output is cached
(``.bench_cache/``, see ``benchmarks/rep_data.py``).

Run: ``nice -n 5 .venv/bin/python benchmarks/rep_diagnosis.py [--actors bd] [--seeds 0,1]
[--degradations] [--aggregate] [--counts [--objective]] [--set refine_band=4.0]``. Choose
on one actor (bd); for the held-out actors look at ``--aggregate`` only.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np
from rep_data import KINECT_FPS_STEP, KINECT_NOISE_M, features, load_clips, make_sequences

from streamseg.config import RepetitionConfig
from streamseg.evaluation.datasets import HDM05_REPETITIVE
from streamseg.evaluation.metrics import repetition_accuracy
from streamseg.offline import repetition_steps as steps
from streamseg.offline.rep_align import align_repetitions, dtw_cost
from streamseg.offline.rep_analysis import not_repetitive_reason
from streamseg.offline.repetition import RepetitionSegmenter
from streamseg.recording import Recording

BINS = (0.0, 0.05, 0.1, 0.2, 0.35, 0.5, np.inf)


def _sub30(reps, n):
    return [(min(n, int(np.ceil(a / KINECT_FPS_STEP))), min(n, int(np.ceil(b / KINECT_FPS_STEP))))
            for a, b in reps]


def degraded(seqs, base, seed):
    """The clean sequences with one degradation each: "30 Hz", "noise" and "clean@30"."""
    out = []
    rng = np.random.default_rng(10_000 + seed)
    for s in seqs:
        if s["cond"] != "clean":
            continue
        rec = s["recording"]
        p30 = rec.positions[::KINECT_FPS_STEP]
        n30 = p30.shape[0]
        common = {"cls": s["cls"], "actor": s["actor"], "seed": s.get("seed", -1)}
        d = {**common, "cond": "30 Hz", "fps": 120.0 / KINECT_FPS_STEP,
             "reps": _sub30(s["reps"], n30),
             "recording": Recording(120.0 / KINECT_FPS_STEP, rec.skeleton, p30,
                                    source=rec.source),
             "key": s["key"][:-len("/clean")] + "/30hz-only"}
        out.append(d)
        noisy = rec.positions + rng.normal(0.0, KINECT_NOISE_M, rec.positions.shape)
        out.append({**common, "cond": "noise", "fps": 120.0, "reps": s["reps"],
                    "recording": Recording(120.0, rec.skeleton, noisy, source=rec.source),
                    "key": s["key"][:-len("/clean")] + "/noise-only"})
        out.append({**common, "cond": "clean@30", "fps": 120.0 / KINECT_FPS_STEP,
                    "reps": _sub30(s["reps"], n30), "sub_of": s})
    for d in out:
        if "sub_of" in d:
            d["X"] = d.pop("sub_of")["X"][::KINECT_FPS_STEP]
        else:
            d["X"] = features(d, base)
    return out


def _terms(found, truth):
    D = min(len(found), len(truth))
    return [abs((fb - fa) - (tb - ta)) / (tb - ta)
            for (fa, fb), (ta, tb) in zip(found[:D], truth[:D])]


def _cuts(reps):
    return [a for a, _ in reps] + [reps[-1][1]]


def _tile(cuts):
    return list(zip(cuts[:-1], cuts[1:]))


def _oracle_snap(dtw, truth, fraction):
    """Each inner DTW cut moved onto its true join when the join is inside the snap window."""
    cuts = _cuts(dtw)
    out = list(cuts)
    joins = _cuts(truth)
    for i in range(1, len(cuts) - 1):
        r = int(fraction * min(cuts[i] - cuts[i - 1], cuts[i + 1] - cuts[i]))
        if abs(joins[i] - cuts[i]) <= r:
            out[i] = joins[i]
    return _tile(out)


def analyse_all(seqs, cfg):
    """Per sequence: found repetitions under the defaults and under the stage variants."""
    stages = {"spectral": replace(cfg, align="none"), "tiling": replace(cfg, align_snap=0.0)}
    for s in seqs:
        s["found"] = RepetitionSegmenter(cfg, s["fps"]).fit(s["X"]).repetitions_
        for name, c in stages.items():
            s[name] = RepetitionSegmenter(c, s["fps"]).fit(s["X"]).repetitions_


def _spectral(seg, cfg):
    """The count before the DTW re-cut (the spectral boundaries, as ``align="none"``)."""
    a = seg.analysis_
    if a is None or not_repetitive_reason(a, cfg):
        return []
    reps = steps.to_repetitions(a.boundaries, seg.n_frames_, a.period, cfg.edge_fraction,
                                a.speed2, merge_edges=cfg.merge_edges)
    return reps if not not_repetitive_reason(a, cfg, len(reps)) else []


def _merged_split(found, truth, margin=0.25):
    """(found pieces holding a true join inside, true repetitions holding a found cut inside):
    inside = more than ``margin`` of the true repetition's length from its ends."""
    joins = _cuts(truth)[1:-1]
    merged = sum(any(a < j < b and min(j - a, b - j) > margin * np.median(
        [tb - ta for ta, tb in truth]) for j in joins) for a, b in found)
    cuts = _cuts(found)[1:-1] if found else []
    split = sum(any(ta + margin * (tb - ta) < c < tb - margin * (tb - ta) for c in cuts)
                for ta, tb in truth)
    return merged, split


def count_cause(s, cfg):
    """Why a sequence's count is wrong: (stage, cause) strings."""
    seg, truth, found = s["seg"], s["reps"], s["found"]
    n_true = len(truth)
    if not found:
        a = seg.analysis_
        why = seg.reason_
        kind = ("subharmonic" if "harmonic" in why else "concentration" if "concentration" in why
                else "cycles" if "cycles" in why else why[:20])
        extra = f" {a.subharmonic:.2f}" if a is not None and kind == "subharmonic" else ""
        return "rejected", f"{kind}{extra}"
    spec = s["spec"]
    cyc = seg.analysis_.primary_cycles
    period_ok = abs(cyc - n_true) < 0.5
    merged, split = _merged_split(found, truth)
    shape = f"merged {merged} split {split}"
    if len(spec) == n_true:
        return "DTW re-cut", shape
    where = (f"period ok ({cyc:.1f} cycles)" if period_ok else
             f"period {'long' if cyc < n_true else 'short'} ({cyc:.1f} cycles for {n_true})")
    stage = "spectral" if len(found) == len(spec) else "spectral+DTW"
    return stage, f"{where}; {shape}"


def tiling_costs(s, cfg):
    """(template length, objective of the true tiling, of the pieces found), at the
    alignment's rate, over the stretch the re-cut covered; None when it did not run."""
    seg, spec = s["seg"], s["spec"]
    a = seg.analysis_
    if cfg.align != "dtw" or len(spec) < 2:
        return None
    F = seg.alignment_features(a)[0]
    pieces, used = align_repetitions(
        F, spec, seg.fps_, rate_hz=cfg.align_rate_hz, stretch=cfg.align_stretch,
        iterations=cfg.align_iterations, max_slope=cfg.align_max_slope,
        max_compress=cfg.align_max_compress, return_template=True)
    if used is None:
        return None
    q = max(1, int(round(seg.fps_ / cfg.align_rate_hz)))
    s0, s1 = pieces[0][0], pieces[-1][1]
    Fd = F[s0:s1:q]
    T = F[used[0]:used[1]:q]

    def objective(cuts):
        d = sorted({min(len(Fd), max(0, int(round((c - s0) / q)))) for c in cuts})
        return sum((y - x) * dtw_cost(T, Fd[x:y], cfg.align_max_slope, cfg.align_max_compress)
                   for x, y in zip(d[:-1], d[1:]) if y > x)

    true_cuts = [s0] + [c for c in _cuts(s["reps"])[1:-1] if s0 < c < s1] + [s1]
    return len(T), objective(true_cuts), objective(_cuts(pieces))


def count_report(seqs, cfg, objective=False):
    """Class x actor x (over, under, exact) per condition, then each wrong count's cause."""
    conds = list(dict.fromkeys(s["cond"] for s in seqs))
    classes = sorted({s["cls"] for s in seqs})
    actors = sorted({s["actor"] for s in seqs})
    print("\nCOUNTS: over / under / exact sequences (DTW re-cut, the defaults; in brackets the "
          "spectral count alone)")
    for c in conds:
        print(f"\n{c}")
        print(f"{'class':28s} " + " ".join(f"{a:>22s}" for a in actors + ['all']))
        for k in classes + ["all"]:
            cells = []
            for act in actors + ["all"]:
                v = [s for s in seqs if s["cond"] == c and (k == "all" or s["cls"] == k)
                     and (act == "all" or s["actor"] == act)]
                e = [len(s["found"]) - len(s["reps"]) for s in v]
                e0 = [len(s["spec"]) - len(s["reps"]) for s in v]
                cells.append(f"{sum(x > 0 for x in e)}/{sum(x < 0 for x in e)}/"
                             f"{sum(x == 0 for x in e)} ({sum(x > 0 for x in e0)}/"
                             f"{sum(x < 0 for x in e0)}/{sum(x == 0 for x in e0)})")
            print(f"{k[:28]:28s} " + " ".join(f"{x:>22s}" for x in cells))
    print("\nwrong counts: stage and cause (stage: rejected = counted 0 by the repetitive test; "
          "spectral = the count before the re-cut already wrong; DTW re-cut = spectral count "
          "right, the tiling changed it; merged/split = found pieces holding a true join / true "
          "repetitions holding a found cut, away from their ends)")
    print(f"{'condition':9s} {'actor':5s} {'class':16s} {'seed':>4s} {'true':>4s} {'spec':>4s} "
          f"{'found':>5s} {'stage':12s} cause" + ("; objective true / found" if objective else ""))
    tally = {}
    for s in seqs:
        if len(s["found"]) == len(s["reps"]):
            continue
        stage, cause = count_cause(s, cfg)
        sign = "over" if len(s["found"]) > len(s["reps"]) else "under"
        key = (s["cond"], stage, sign)
        tally[key] = tally.get(key, 0) + 1
        obj = ""
        if objective:
            tc = tiling_costs(s, cfg)
            if tc is not None:
                ratio = tc[1] / tc[2] if tc[2] > 0 else np.inf
                obj = f"; template {tc[0]} frames, {tc[1]:.1f} / {tc[2]:.1f} = {ratio:.2f}"
                k = (s["cond"], "objective", "prefers found" if ratio >= 1 else "search missed")
                tally[k] = tally.get(k, 0) + 1
        print(f"{s['cond']:9s} {s['actor']:5s} {s['cls'][:16]:16s} {s['seed']:4d} "
              f"{len(s['reps']):4d} {len(s['spec']):4d} {len(s['found']):5d} {stage:12s} {cause}"
              + obj)
    print("\ntally: condition, stage, over/under: sequences")
    for key in sorted(tally):
        print(f"{key[0]:9s} {key[1]:12s} {key[2]:13s} {tally[key]:3d}")


def report(seqs, cfg, aggregate):
    conds = list(dict.fromkeys(s["cond"] for s in seqs))
    by = {c: [s for s in seqs if s["cond"] == c] for c in conds}
    exact = {c: [s for s in v if s["found"] and len(s["found"]) == len(s["reps"])]
             for c, v in by.items()}
    print("\n1. the loss (1 - mean alpha) split by where it arises, in alpha points")
    print(f"{'condition':10s} {'n':>3s} {'alpha':>6s} {'exact':>6s} {'loss':>6s} | "
          f"{'count 0':>7s} {'miscount':>8s} | exact: {'first':>6s} {'middle':>6s} {'last':>6s}")
    for c, v in by.items():
        N = len(v)
        part = dict.fromkeys(("zero", "mis", "first", "middle", "last"), 0.0)
        for s in v:
            T = _terms(s["found"], s["reps"])
            if not T:
                part["zero"] += 1.0 / N
            elif len(s["found"]) != len(s["reps"]):
                part["mis"] += sum(T) / len(T) / N
            else:
                for i, x in enumerate(T):
                    pos = "first" if i == 0 else "last" if i == len(T) - 1 else "middle"
                    part[pos] += x / len(T) / N
        alpha = np.mean([repetition_accuracy(s["found"], s["reps"]) for s in v])
        print(f"{c:10s} {N:3d} {alpha:6.3f} {len(exact[c]) / N:6.2f} {1 - alpha:6.3f} | "
              f"{part['zero']:7.3f} {part['mis']:8.3f} |        {part['first']:6.3f} "
              f"{part['middle']:6.3f} {part['last']:6.3f}")
    if not aggregate:
        print("\n2. per class: alpha (exactly counted / sequences)")
        classes = sorted({s["cls"] for s in seqs})
        print(f"{'class':28s} " + " ".join(f"{c:>14s}" for c in conds))
        for k in classes:
            cells = []
            for c in conds:
                v = [s for s in by[c] if s["cls"] == k]
                a = np.mean([repetition_accuracy(s["found"], s["reps"]) for s in v])
                e = sum(len(s["found"]) == len(s["reps"]) for s in v)
                cells.append(f"{a:.3f} ({e}/{len(v)})")
            print(f"{k[:28]:28s} " + " ".join(f"{x:>14s}" for x in cells))
    print("\n3. boundaries, mean alpha over all sequences (only exactly counted ones are "
          "changed in the last five columns)")
    print(f"{'condition':10s} {'found':>6s} | {'outer true':>10s} {'inner true':>10s} | "
          f"{'spectral':>8s} {'tiling':>6s} {'+snap':>6s} {'oracle snap':>11s}")
    for c, v in by.items():
        cols = {k: [] for k in ("found", "outer", "inner", "spectral", "tiling", "snap",
                                "oracle")}
        for s in v:
            f, t = s["found"], s["reps"]
            a = repetition_accuracy(f, t)
            cols["found"].append(a)
            if not f or len(f) != len(t):
                for k in ("outer", "inner", "spectral", "tiling", "snap", "oracle"):
                    cols[k].append(a)
                continue
            fc, tc = _cuts(f), _cuts(t)
            cols["outer"].append(repetition_accuracy(_tile([tc[0], *fc[1:-1], tc[-1]]), t))
            cols["inner"].append(repetition_accuracy(_tile([fc[0], *tc[1:-1], fc[-1]]), t))
            cols["spectral"].append(repetition_accuracy(s["spectral"], t))
            cols["tiling"].append(repetition_accuracy(s["tiling"], t))
            cols["snap"].append(a)
            til = s["tiling"]
            orc = (_oracle_snap(til, t, cfg.align_snap) if len(til) == len(t) and len(t) >= 2
                   else f)
            cols["oracle"].append(repetition_accuracy(orc, t))
        m = {k: np.mean(x) for k, x in cols.items()}
        print(f"{c:10s} {m['found']:6.3f} | {m['outer']:10.3f} {m['inner']:10.3f} | "
              f"{m['spectral']:8.3f} {m['tiling']:6.3f} {m['snap']:6.3f} {m['oracle']:11.3f}")
    print("\n4. exactly counted sequences: repetitions by |length error| / true length "
          "(number, loss in alpha points)")
    print(f"{'condition':10s} " + " ".join(f"{'< ' + format(b, 'g'):>12s}" for b in BINS[1:]))
    for c, v in by.items():
        cnt = np.zeros(len(BINS) - 1, int)
        loss = np.zeros(len(BINS) - 1)
        for s in exact[c]:
            T = _terms(s["found"], s["reps"])
            for x in T:
                j = int(np.searchsorted(BINS, x, side="right")) - 1
                cnt[j] += 1
                loss[j] += x / len(T) / len(v)
        print(f"{c:10s} " + " ".join(f"{n:5d} {x:6.3f}" for n, x in zip(cnt, loss)))
    print("\n5. exactly counted sequences: (found - true) / true length by position, mean "
          "(mean of |.|)")
    print(f"{'condition':10s} {'first':>15s} {'middle':>15s} {'last':>15s}")
    for c in conds:
        pos = {"first": [], "middle": [], "last": []}
        for s in exact[c]:
            f, t = s["found"], s["reps"]
            for i, ((fa, fb), (ta, tb)) in enumerate(zip(f, t)):
                key = "first" if i == 0 else "last" if i == len(t) - 1 else "middle"
                pos[key].append(((fb - fa) - (tb - ta)) / (tb - ta))
        print(f"{c:10s} " + " ".join(
            f"{np.mean(x):+7.3f} ({np.mean(np.abs(x)):.3f})" if x else f"{'-':>15s}"
            for x in pos.values()))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--actors", default="bd", help="comma-separated HDM05 actors (default bd)")
    ap.add_argument("--seeds", default="0,1", help="draws of sequences (default 0,1)")
    ap.add_argument("--per-pair", type=int, default=3, help="sequences per actor, class, seed")
    ap.add_argument("--degradations", action="store_true",
                    help="also each Kinect-like degradation alone (30 Hz; noise; clean@30)")
    ap.add_argument("--aggregate", action="store_true",
                    help="no per-class table (for actors held out of the choice)")
    ap.add_argument("--counts", action="store_true",
                    help="the wrong counts: class x actor x (over, under, exact), and why")
    ap.add_argument("--objective", action="store_true",
                    help="with --counts: the DTW objective of the true tiling vs the found one")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                    help="a RepetitionConfig field changed for the analysis (not the UKF cache "
                         "key's fields), e.g. --set refine_band=3.0; repeatable")
    args = ap.parse_args(argv)
    actors = args.actors.split(",")
    base = RepetitionConfig()
    changes = {}
    for item in args.set:
        key, _, value = item.partition("=")
        if not hasattr(base, key):
            ap.error(f"--set {item}: RepetitionConfig has no field {key!r}")
        kind = type(getattr(base, key))
        changes[key] = (value.lower() in ("1", "true", "yes")) if kind is bool else kind(value)
    cfg = replace(base, **changes)
    clips, names = load_clips()
    t0 = time.perf_counter()
    seqs = []
    for seed in (int(x) for x in args.seeds.split(",")):
        drawn = [s for s in make_sequences(clips, names, args.per_pair, seed,
                                           classes=set(HDM05_REPETITIVE))
                 if s["actor"] in actors]
        for s in drawn:
            s["X"] = features(s, cfg)  # the UKF cache key holds no field --set may change
            s["seed"] = seed
        seqs += drawn
        if args.degradations:
            seqs += degraded(drawn, cfg, seed)
    if args.counts:
        for s in seqs:
            s["seg"] = RepetitionSegmenter(cfg, s["fps"]).fit(s["X"])
            s["found"] = s["seg"].repetitions_
            s["spec"] = _spectral(s["seg"], cfg)
        print(f"actors {args.actors}, seeds {args.seeds}: {len(seqs)} sequences "
              f"({time.perf_counter() - t0:.0f} s){'; ' + str(changes) if changes else ''}")
        count_report(seqs, cfg, args.objective)
        return
    analyse_all(seqs, cfg)
    print(f"actors {args.actors}, seeds {args.seeds}: {len(seqs)} sequences "
          f"({time.perf_counter() - t0:.0f} s, UKF cached){'; ' + str(changes) if changes else ''}")
    report(seqs, cfg, args.aggregate)


if __name__ == "__main__":
    main()
