"""Why the live cuts miss and what the false ones are, per recording (issue 11, round 7).

The library's streaming decision is replayed window by window (``benchmarks/_lof_replay.py``,
checked first to give the library's cuts) with a trace of where each window's decision stopped:
"gap" (within ``min_gap_s`` of the previous cut), "threshold" (LOF below median + 1 MAD-sigma),
"peak" (above it but no Douglas-Peucker peak dominating its neighbours), "after" (too few
frames after the localised cut), "contrast" (2 s before/after contrast below 0.15),
"novelty" (segment/after contrast below 0.15) or "cut".

Each TRUE cut gets one cause, the furthest stage any window could have carried it to. Its
candidate windows are those whose centre lies within its acceptance window (label window +
0.5 s, else +-0.5 s) widened by the localisation radius ``refine_s``, so that localisation
could have brought them in:

- hit: a cut matched it (the scorer's matching);
- no peak: no candidate window is a local maximum of the LOF curve the decision saw;
- below threshold / not a DP peak / gap: the furthest stage of any candidate window (gap: a
  cut, usually a false one, was made within ``min_gap_s`` before; its frame is printed);
- localised away: a candidate passed the peak rule but localisation put the cut outside the
  acceptance window (the frame is printed);
- contrast / novelty: a candidate localised inside the window was rejected by that check.

Each FALSE cut is classed: "beside a hit" (within 1.5 s of a true cut that another cut
matched: a second cut of one transition), "near a miss" (within 1.5 s of a true cut nobody
matched: a placement error) or "inside action" (farther: a sub-movement or a change inside one
labelled action). It is printed with the labelled segment it falls in, its place in it (seconds
from the segment's start / to its end), its LOF and threshold, contrast and novelty, and
"recur": the smallest cosine distance between the histogram of the 2 s after it and any 2 s
of the current segment before it (every 0.2 s since the previous cut, unbounded history, a
diagnostic only): small when the motion after the cut is one the segment already held, as
when sub-movements alternate. Hits get the same columns, for comparison.

The three recordings below F1 0.4 with the defaults (hdm_bk_2, 02_walk_punch_sword_wash,
02_wash_sword_walk_punch) are printed by default; ``--all`` prints every recording of
``benchmarks/lof_accuracy.py``. These are diagnoses, not choices: round 7's mechanism, the
recurrence check, was chosen on 14_20 + hdm_bk_1 (``benchmarks/lof_recur.py``, not adopted).

Run: .venv/bin/python benchmarks/lof_misses.py [--all | --only NAME,NAME]   (half a minute;
``--only`` also takes the fresh sets' joins, e.g. fresh2_bk_1)
"""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from _lof_replay import decide, snapshots  # noqa: E402
from lof_accuracy import FPS, features, lof_cuts, recordings  # noqa: E402

from streamseg.config import LOFConfig  # noqa: E402
from streamseg.evaluation.datasets import (  # noqa: E402
    CMU02_MULTI_ACTION_SEQUENCES,
    CMU02_SEQUENCES,
    CMU02_TRIAL_ACTIONS,
    hdm05_action_plans,
)
from streamseg.evaluation.labels import read_labels  # noqa: E402
from streamseg.evaluation.metrics import cut_windows_from, match_cuts  # noqa: E402
from streamseg.offline.lof import frame_bins  # noqa: E402
from streamseg.online.speed_features import lof_columns  # noqa: E402

#: a false cut this close to a true cut is counted as a placement error ("beside a hit": a second
#: cut of that transition; "near a miss": the true cut placed outside its acceptance window)
NEAR_S = 1.5
LOW = ("hdm_bk_2", "02_walk_punch_sword_wash", "02_wash_sword_walk_punch")
DATA = ROOT / "data"
#: the order of the stages a window's decision passes (a cause is the furthest reached)
STAGES = ("gap", "threshold", "peak", "after", "contrast", "novelty", "recur", "cut")


def segment_labels(name, truth, n):
    """``[(start, end, label), ...]`` of a recording of lof_accuracy.recordings()."""
    if name == "86_01":
        return [(s.start, s.end, s.label) for s in
                read_labels(DATA / "cmu86" / "labels_86_01.csv", name)]
    if name in ("14_14", "14_20"):
        return [(s.start, s.end, s.label) for s in
                read_labels(DATA / "cmu_exercise" / "labels.csv", name)]
    if name.startswith("02_"):
        names = [CMU02_TRIAL_ACTIONS[t][0] for t in CMU02_SEQUENCES[name]]
    else:
        names = [cls for cls, _ in _plans()[name][1]]
    b = [0, *truth, n]
    return [(b[i], b[i + 1], names[i]) for i in range(len(names))]


def _plans():
    """The HDM05 join plans of every set: the 14's hdm, the fresh nine, the fresh2 four."""
    from lof_confirm import FRESH_SEED
    from lof_pelvis2 import fresh2_plans

    old = hdm05_action_plans(DATA)
    fresh = hdm05_action_plans(DATA, per_actor=3, seed=FRESH_SEED, exclude=old, prefix="fresh")
    return {**old, **fresh, **fresh2_plans(DATA)}


def where(frame, segs):
    for s, e, lab in segs:
        if s <= frame < e:
            return f"{lab} +{(frame - s) / FPS:.1f}/-{(e - frame) / FPS:.1f} s"
    return "-"


def recurrence(cum, cf, seg0, seen, length, step):
    """Smallest cosine distance between the after side (``length`` frames, clipped to
    ``seen``) and any ``length`` frames of ``seg0 .. cf`` (every ``step`` frames)."""
    after = (cum[min(cf + length, seen)] - cum[cf]).astype(np.float64)
    best = np.inf
    for s in range(seg0, cf - length + 1, step):
        a = (cum[s + length] - cum[s]).astype(np.float64)
        den = np.sqrt((a @ a) * (after @ after))
        if den > 0:
            best = min(best, 1.0 - (a @ after) / den)
    return best


def diagnose(name, a, truth, windows, config, out):
    g = config.frames(FPS)
    half = int(0.5 * FPS)
    snaps = snapshots(a, config, FPS)
    trace = []
    cuts, _ = decide(a, config, FPS, snaps, trace=trace)
    lib = lof_cuts(a, config, True)[0]
    if cuts != lib:
        raise SystemExit(f"{name}: the replay {cuts} differs from the library {lib}")
    bins_, valid = frame_bins(lof_columns(a, config, FPS), config.bins)
    onehot = np.zeros((len(a), bins_.shape[1] * config.bins), dtype=np.int64)
    cols = np.arange(bins_.shape[1]) * config.bins + bins_.astype(np.int64)
    onehot[np.arange(len(a))[:, None], cols] = valid[:, None]
    cum = np.vstack([np.zeros((1, onehot.shape[1]), dtype=np.int64), np.cumsum(onehot, 0)])
    acc = cut_windows_from(truth, tolerance=None if windows else half, windows=windows,
                           margin=half if windows else 0)
    pairs = match_cuts(cuts, truth, tolerance=None if windows else half, windows=windows,
                       margin=half if windows else 0)
    hit_true = {j: cuts[i] for i, j in pairs}
    hit_pred = {i for i, _ in pairs}
    segs = segment_labels(name, truth, len(a))
    by_frame = {r["frame"]: r for r in trace if r["stage"] == "cut"}
    # the LOF curve each window's decision saw: local maxima among its decided neighbours
    lof_at = {r["w"]: r.get("lof") for r in trace}

    def local_max(w):
        y = lof_at.get(w)
        return y is not None and all(lof_at.get(v) is None or lof_at[v] <= y
                                     for v in (w - 1, w + 1))

    def cols_of(r, cf):
        rec = recurrence(cum, cf, r["seg0"], r["seen"], g["contrast"], g["step"])
        return (f"lof {r.get('lof', 0):.2f}/thr {r.get('thr', 0):.2f} con {r.get('con', 0):.2f} "
                f"nov {r.get('nov', 0):.2f} recur {rec:.2f}")

    print(f"\n{name}: {len(truth)} true cuts, {len(cuts)} cuts, {len(pairs)} correct")
    for j, t in enumerate(truth):
        lo, hi = acc[j]
        lab = where(t, segs)
        if j in hit_true:
            cf = hit_true[j]
            cause = "hit"
            print(f"  true {t:6d} ({lab:34s}) hit at {cf:6d}   {cols_of(by_frame[cf], cf)}")
            out[cause] += 1
            continue
        cand = [r for r in trace if lo - g["refine"] <= r["centre"] <= hi + g["refine"]]
        inside = [r for r in cand if "frame" in r and lo <= r["frame"] <= hi]
        passed = [r for r in cand if "frame" in r]
        detail = ""
        if inside:
            r = max(inside, key=lambda r: STAGES.index(r["stage"]))
            cause = r["stage"] if r["stage"] != "cut" else "matched elsewhere"
            detail = cols_of(r, r["frame"])
        elif passed:
            r = passed[0]
            cause = "localised away"
            detail = f"to {r['frame']} ({(r['frame'] - t) / FPS:+.2f} s)"
        elif not any(local_max(r["w"]) for r in cand if r["stage"] != "gap"):
            gaps = [r for r in cand if r["stage"] == "gap"]
            cause = "gap" if gaps and len(gaps) == len(cand) else "no peak"
            if gaps:
                detail = f"previous cut at {gaps[0]['seg0']}"
        else:
            r = max(cand, key=lambda r: STAGES.index(r["stage"]))
            cause = {"threshold": "below threshold", "peak": "not a DP peak"}.get(
                r["stage"], r["stage"])
            best = max((x for x in cand if x.get("lof") is not None), key=lambda x: x["lof"])
            detail = f"best lof {best['lof']:.2f}, thr {best['thr']:.2f}"
        out[cause] += 1
        print(f"  true {t:6d} ({lab:34s}) MISSED: {cause}  {detail}")
    for i, cf in enumerate(cuts):
        if i in hit_pred:
            continue
        r = by_frame[cf]
        j = int(np.argmin([abs(t - cf) for t in truth]))
        near = truth[j]
        kind = ("inside action" if abs(cf - near) > NEAR_S * FPS else
                "beside a hit" if j in hit_true else "near a miss")
        out[f"false: {kind}"] += 1
        print(f"  false {cf:6d} ({where(cf, segs):34s}) {kind:13s} nearest true {near} "
              f"({(cf - near) / FPS:+.1f} s)  {cols_of(r, cf)}")


def main():
    recs = {k: v for k, v in recordings().items() if k not in CMU02_MULTI_ACTION_SEQUENCES}
    names = (list(recs) if "--all" in sys.argv else
             sys.argv[sys.argv.index("--only") + 1].split(",") if "--only" in sys.argv
             else list(LOW))
    if any(n.startswith("fresh") for n in names):  # the held-out sets, named with --only
        from lof_confirm import fresh_recordings
        from lof_pelvis2 import fresh2_recordings

        recs.update(fresh_recordings(), **fresh2_recordings())
    config = LOFConfig()
    total = Counter()
    for name in names:
        r, truth, windows = recs[name]
        a = np.ascontiguousarray(features(r, True))
        out = Counter()
        diagnose(name, a, list(truth), windows, config, out)
        print("  causes: " + ", ".join(f"{k} {v}" for k, v in sorted(out.items())))
        total += out
    print("\nall printed recordings: " + ", ".join(f"{k} {v}" for k, v in sorted(total.items())))


if __name__ == "__main__":
    main()
