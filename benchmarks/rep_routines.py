"""Parts 2 and 3 of ``benchmarks/repetitions.py``: whole routines per set, the live counter.

Routines:
- CMU 14_14 and 14_20: exercise blocks labelled by people (12-frame resolution); no
  repetition labels, so the counts found are printed for inspection only.
- One HDM05 routine per actor (``routine_plan``): squat x5, depositFloorR, elbow-to-knee x5,
  grabHighR, two-leg hop x5, throwBasketball, front kick x5 (repetitive classes as a set of
  five consecutive takes, action classes one take; takes not used twice). Every join, between
  classes and between the takes of a set, is abrupt (clips end and start near the rest pose,
  but no natural transition).
"""

from __future__ import annotations

import csv
import time

import numpy as np
from rep_data import DATA, features, load_clips, make_sequences

from streamseg.evaluation.datasets import (
    HDM05_ACTORS,
    HDM05_REPETITIVE,
    hdm05_clips,
    hdm05_sequence,
)
from streamseg.io import read
from streamseg.offline.repetition import RepetitionSegmenter
from streamseg.offline.sets import RoutineSegmenter
from streamseg.online.repetition import RepetitionCounter

ROUTINE = (("squat1Reps", 5), ("depositFloorR", 1), ("elbowToKnee1RepsLelbowStart", 5),
           ("grabHighR", 1), ("hopBothLegs1hops", 5), ("throwBasketball", 1),
           ("kickLFront1Reps", 5))


def routine_plan(actor):
    clips = hdm05_clips(DATA)
    return [(cls, clips[actor, cls][:n]) for cls, n in ROUTINE]


def hdm_routine(actor):
    """(recording, true sets [(start, end, name, true count or None)])."""
    parts = routine_plan(actor)
    rec, starts = hdm05_sequence(DATA, actor, parts)
    bounds = [0, *starts, rec.n_frames]
    truth = [(a, b, cls, n if cls in HDM05_REPETITIVE else None)
             for (a, b), (cls, n) in zip(zip(bounds[:-1], bounds[1:]), ROUTINE)]
    return rec, truth


def cmu_routines():
    blocks = {}
    with open(DATA / "cmu_exercise" / "labels.csv", newline="") as fh:
        for row in csv.DictReader(fh):
            blocks.setdefault(row["sequence"], []).append(
                (int(row["start_frame"]) - 1, int(row["end_frame"]), row["action_label"], None))
    for seq, truth in sorted(blocks.items()):
        rec = read(DATA / "cmu_exercise" / f"{seq}.amc.gz", skeleton=DATA / "cmu86" / "86.asf")
        yield seq, rec, truth


def report_routine(name, rec, truth, cfg, totals):
    t0 = time.perf_counter()
    r = RoutineSegmenter(cfg).fit(rec)
    secs = time.perf_counter() - t0
    fps = rec.fps
    found_b = np.array([st.start for st in r.sets_[1:]])
    print(f"\n{name}: {rec.n_frames} frames, {len(r.sets_)} sets found ({r.n_clusters_} actions), "
          f"{len(truth)} true; {secs:.0f} s")
    print(f"  {'true set':30s} {'frames':>11s} {'true':>4s} | {'found sets (label: count)':40s}"
          f" {'count':>5s} {'start err s':>11s}")
    for a, b, lab, n in truth:
        inside = [st for st in r.sets_ if max(st.start, a) < min(st.end, b)
                  and (min(st.end, b) - max(st.start, a)) >= 0.5 * (st.end - st.start)]
        count = sum(st.count for st in inside)
        desc = " ".join(f"[{st.start}-{st.end}) {st.label}:{st.count if st.repetitive else '-'}"
                        for st in inside)
        err = ""
        if a > 0 and found_b.size:
            e = float(np.min(np.abs(found_b - a)) / fps)
            err = f"{e:11.2f}"
            totals["bound"].append(e)
        tn = "-" if n is None else str(n)
        print(f"  {lab[:30]:30s} {a:5d}-{b:5d} {tn:>4s} | {desc[:40]:40s} {count:5d} {err}")
        if n is not None:
            totals["exact"].append(count == n)
        elif name.startswith("hdm"):
            totals["action0"].append(count == 0)


def run_routines(args, cfg):
    totals = {"bound": [], "exact": [], "action0": []}
    print("\n=== Part 2: routines, split into sets (HACA, K found) and counted per set ===")
    print("(HDM05 routines: joined clips, every join abrupt; CMU: counts for inspection, no "
          "repetition labels)")
    for seq, rec, truth in cmu_routines():
        report_routine(seq, rec, truth, cfg, totals)
    cmu_bound = list(totals["bound"])
    for actor in HDM05_ACTORS:
        rec, truth = hdm_routine(actor)
        report_routine(f"hdm_routine_{actor}", rec, truth, cfg, totals)
    hdm_bound = totals["bound"][len(cmu_bound):]
    print("\nsummary: distance of each true set start to the nearest found set start "
          f"(median / max s): CMU {np.median(cmu_bound):.2f} / {np.max(cmu_bound):.2f}, "
          f"HDM05 {np.median(hdm_bound):.2f} / {np.max(hdm_bound):.2f}")
    print(f"HDM05 repetitive sets counted exactly: {sum(totals['exact'])} of "
          f"{len(totals['exact'])}; action takes counted 0: {sum(totals['action0'])} of "
          f"{len(totals['action0'])}")


def live_counts(positions, rec, chunk=30, cfg=None):
    counter = RepetitionCounter(cfg, rec.fps, rec.skeleton)
    events = []
    for i in range(0, rec.n_frames, chunk):
        events += counter.learn_many(positions[i:i + chunk])
    return events, events + counter.finish()


def run_live(args, cfg):
    print("\n=== Part 3: the live counter (RepetitionCounter, 30-frame packets, then finish()) "
          "over the HDM05 sequences of part 1 ===")
    clips, names = load_clips()
    seqs = make_sequences(clips, names, args.per_pair, args.seed, classes=set(HDM05_REPETITIVE))
    rows = []
    delays, first_err, t_live = [], [], 0.0
    for s in seqs:
        rec = s["recording"]
        off = RepetitionSegmenter(cfg, s["fps"]).fit(features(s, cfg))
        t0 = time.perf_counter()
        ev, ev_end = live_counts(rec.positions, rec, cfg=cfg)
        t_live += time.perf_counter() - t0
        live = ev_end[-1].count if ev_end else 0
        live_nofinish = ev[-1].count if ev else 0
        true_ends = np.array([b for _, b in s["reps"]])
        mean_len = np.mean([b - a for a, b in s["reps"]])
        for e in ev:
            delays.append((e.emitted_at - e.end) / s["fps"])
        for e in ev[:3]:
            first_err.append(float(np.min(np.abs(true_ends - e.end)) / mean_len))
        # repetitions that had ended before the first event was emitted are "caught up"
        rows.append((s["cond"], s["cls"], live, off.count_, len(s["reps"]), live_nofinish))
    print(f"{'condition':9s} {'class':28s} {'n':>3s} {'live=offline':>12s} {'live=true':>9s} "
          f"{'live MAE':>8s} {'no event':>8s} {'MAE before finish':>17s}")
    for cond in ("clean", "kinect"):
        for cls in sorted(set(r[1] for r in rows)) + ["ALL"]:
            v = [r for r in rows if r[0] == cond and (cls == "ALL" or r[1] == cls)]
            live = np.array([r[2] for r in v])
            off = np.array([r[3] for r in v])
            true = np.array([r[4] for r in v])
            print(f"{cond:9s} {cls[:28]:28s} {len(v):3d} {np.mean(live == off):12.2f} "
                  f"{np.mean(live == true):9.2f} {np.abs(live - true).mean():8.2f} "
                  f"{np.mean(live == 0):8.2f} "
                  f"{np.abs(np.array([r[5] for r in v]) - true).mean():17.2f}")
    d = np.array(delays)
    print(f"rep event delay (emitted_at - end), s: median {np.median(d):.2f}, p90 "
          f"{np.percentile(d, 90):.2f}, max {d.max():.2f} ({d.size} events)")
    fe = np.array(first_err)
    print(f"first 3 repetitions of each set: end error / mean repetition length: median "
          f"{np.median(fe):.2f}, p90 {np.percentile(fe, 90):.2f} ({fe.size} events)")
    motion = sum(s["recording"].n_frames / s["fps"] for s in seqs)
    print(f"live compute: {t_live / motion:.3f} s per second of motion")


def run(args, cfg):
    if args.routines:
        run_routines(args, cfg)
    if args.live:
        run_live(args, cfg)

