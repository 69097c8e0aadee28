"""Pelvis-speed columns, round 12 (issue 11): leave-one-out over every labelled recording.

Rounds 10 and 11 (``lof_pelvis.py``, ``lof_pelvis2.py``) each chose v_max on a pair and scored
the rest once; both raised pooled F1 and both lowered the cmu02 mean, so neither was adopted.
This round asks the question the issue asks, over all 27 labelled recordings at once (the 14,
the fresh nine, the fresh2 four): if the value were chosen without a recording, how would that
recording fare? Declared before it ran (this docstring was committed first):

- candidates: ``CANDIDATES``, pelvis off (the defaults) and both columns at v_max 0.5, 1.0,
  1.5, 2.0 m/s (round 10's and 11's mechanism unchanged: ``lof_pelvis.pelvis_speeds``,
  ``with_pelvis``, the teleport rule ``JUMP_M``);
- for each held-out recording, the candidate with the highest pooled F1 (label window + 0.5 s)
  over the other 26; ties go to pelvis off, then the smaller v_max;
- reported: the held-out recording's F1 under its choice, pooled and per set (cmu, cmu02, hdm,
  fresh, fresh2), beside the defaults; how often each candidate was chosen;
- adoption, all of: LOO pooled F1 >= the defaults' + 0.02; no set's LOO mean below the
  defaults'; no more recordings below 0.4 than the defaults have; median latency <= 2.5 s.

Not blind: rounds 10 and 11 showed every one of these recordings with v_max 1.0 or 0.5, and
the cmu02 loss (the swordplay join localised 0.9 s late) was seen. The rule above was written
knowing that; it is a check that the gain is not an artefact of one train pair, not new
evidence. The pelvis columns are benchmark-only (no library option); adopting them would mean a
``LOFConfig`` option, the daemon's feature pipeline and tests. Joins are abrupt (root teleports
at each join, hence ``JUMP_M``).

Result (2026-12-03, one run, 10 s): LOO chose v_max 1.0 for 25 recordings and 1.5 for two
(14_20, fresh_bd_2); pooled F1 0.719 -> 0.751 (+0.032), cmu 0.833 -> 0.879, hdm 0.745 ->
0.808, fresh 0.730 -> 0.753, fresh2 0.664 -> 0.736, but cmu02 0.450 -> 0.367
(02_walk_punch_sword_wash: the same 9 cuts, one true cut found fewer); 2 recordings below
0.4 before and after (hdm_bk_2 0.29 -> 0.50 leaves the list, fresh2_bk_1 0.00 -> 0.29
stays, 02_walk_punch_sword_wash joins); median latency 2.29 s. NOT adopted (a set lower).

Round 13 (``--lof-only``, declared here and committed before it ran): round 12's loss is
localisation (02_walk_punch_sword_wash keeps its 9 cuts and finds one true cut fewer; round 10
saw its swordplay join placed 0.9 s late). The pelvis columns then enter the LOF only: the
windows' LOF (neighbours, the curve, the threshold, the peak) reads the 17 features + 2
pelvis columns and their speeds, but the cut's localisation, the 2 s contrast and the novelty
check read the defaults' histograms (the 17 features and their speeds), where the poses
change. Replayed with ``_lof_replay.decide`` (its ``fb``: the frame bins of those checks;
the replay == the library is checked on every recording with the pelvis columns everywhere
first). Candidates: pelvis off and LOF-only at v_max 0.5, 1.0, 1.5, 2.0; the same LOO and the
same adoption rule as round 12; round 12's candidates are not mixed in.

Round 14 (``--library``, declared here and committed before it ran): round 13 passed its
rule, so the mechanism went into the library (``LOFConfig.root_speed_max``,
:mod:`streamseg.online.root_speed`), in units a live stream can use without knowing its length
unit: body scales per second (the mean length of the 8 limb bones in the frame; 0.31-0.36 m on
these five subjects, median 0.315 m), the teleport rule ``root_jump`` = 20 body scales/s (about
6.3 m/s; rounds 10-13: 0.05 m per frame at 120 Hz, 6 m/s). Candidates: root speeds off and
``root_speed_max`` 1.5, 3.0, 4.5, 6.0 (round 13's 0.5-2 m/s grid at the median scale:
0.47-1.9 m/s); features from ``lof_features`` (the library's), cuts from the streaming
detector; the same LOO and rule. If it passes, the library default is the value the folds
chose (the most frequent); streaming == offline cuts are checked on every recording for it.

Results. Round 13 (2026-12-03, one run): every fold chose v_max 1.0 LOF-only; LOO pooled F1
0.719 -> 0.762, cmu 0.833 -> 0.914, cmu02 0.450 -> 0.450, hdm 0.745 -> 0.803, fresh 0.730 ->
0.753, fresh2 0.664 -> 0.736, below 0.4: 2 -> 1, median latency 2.30 s: the rule passed.
Round 14 (2026-12-03, one run, 13 s): every fold chose root_speed_max 3.0; LOO pooled F1 0.719
-> 0.771, cmu 0.833 -> 0.944 (86_01 keeps 1.00), cmu02 0.450 -> 0.450, hdm 0.745 -> 0.815,
fresh 0.730 -> 0.753, fresh2 0.664 -> 0.736, below 0.4: 2 -> 1 (hdm_bk_2 0.29 -> 0.50;
fresh2_bk_1 0.00 -> 0.29 stays), median latency 2.27 -> 2.30 s; streaming == offline on all 27:
ADOPTED, ``LOFConfig.root_speed_max = 3.0`` the default. Three recordings lose (fresh_bd_1
0.89 -> 0.75, fresh_bd_2 0.75 -> 0.57; each one true cut fewer).

Run: .venv/bin/python benchmarks/lof_pelvis_loo.py [--lof-only | --library]   (10 s to 2 min)
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from _lof_replay import decide, snapshots  # noqa: E402
from lof_accuracy import FPS, features, lof_cuts, recordings, score, set_of  # noqa: E402
from lof_confirm import fresh_recordings, pooled  # noqa: E402
from lof_pelvis import pelvis_speeds, with_pelvis  # noqa: E402
from lof_pelvis2 import fresh2_recordings  # noqa: E402

from streamseg.config import LOFConfig  # noqa: E402
from streamseg.evaluation.datasets import CMU02_MULTI_ACTION_SEQUENCES  # noqa: E402
from streamseg.offline.lof import frame_bins, lof_features  # noqa: E402
from streamseg.online.speed_features import lof_columns  # noqa: E402

#: None = pelvis off (the defaults); a float = both pelvis columns at that v_max (m/s)
CANDIDATES = (None, 0.5, 1.0, 1.5, 2.0)
#: a recording below this F1 counts as failed (the issue's "no recording below 0.4")
FLOOR = 0.4
CHECK_OFFLINE = [None]  # the candidate whose offline cuts are checked against streaming
LOF_ONLY = "--lof-only" in sys.argv
LIBRARY = "--library" in sys.argv
if LIBRARY:  # root_speed_max, body scales per second (None: off)
    CANDIDATES = (None, 1.5, 3.0, 4.5, 6.0)


def group(name: str) -> str:
    """The set a recording belongs to: cmu, cmu02, hdm, fresh or fresh2."""
    if name.startswith("fresh2_"):
        return "fresh2"
    return "fresh" if name.startswith("fresh_") else set_of(name)


def label(c) -> str:
    if LIBRARY:
        return "root speeds off" if c is None else f"root_speed_max {c:g}"
    return "pelvis off" if c is None else f"v_max {c:g}" + (" LOF only" if LOF_ONLY else "")


def loo_choices(res, names):
    """``{held-out name: candidate}``: the best pooled F1 over the others, ties to the earlier
    candidate in ``CANDIDATES``."""
    out = {}
    for held in names:
        rest = [n for n in names if n != held]
        scores = [pooled(res[c], rest)[0] for c in CANDIDATES]
        out[held] = CANDIDATES[int(np.argmax(scores))]  # argmax: first of equals
    return out


def main():
    cfg = LOFConfig(root_speed_max=0)  # the pelvis columns fed as features
    recs = {k: v for k, v in recordings().items() if k not in CMU02_MULTI_ACTION_SEQUENCES}
    allrecs = {**recs, **fresh_recordings(), **fresh2_recordings()}
    names = list(allrecs)
    feats = {k: np.ascontiguousarray(features(r, True, root=False))
             for k, (r, _, _) in allrecs.items()}
    vels = {k: pelvis_speeds(r) for k, (r, _, _) in allrecs.items()}

    lof_only = LOF_ONLY

    def run_library(n, v):
        c = LOFConfig(root_speed_max=0.0 if v is None else v)
        a = lof_features(allrecs[n][0], c)
        cuts, lats = lof_cuts(a, c, True)
        if v is not None and v == CHECK_OFFLINE[0] and lof_cuts(a, c, False)[0] != cuts:
            raise SystemExit(f"{n}: offline cuts differ from streaming at {label(v)}")
        return score(cuts, allrecs[n][1], allrecs[n][2], len(a)), list(lats or []), cuts

    def run(n, v):
        if LIBRARY:
            return run_library(n, v)
        a = feats[n] if v is None else with_pelvis(feats[n], vels[n], v)
        cuts, lats = lof_cuts(a, cfg, True)
        if lof_only and v is not None:
            snaps = snapshots(a, cfg, FPS)
            if decide(a, cfg, FPS, snaps)[0] != cuts:  # the replay is the library
                raise SystemExit(f"{n}: the replay differs from the library at v_max {v}")
            fb17 = frame_bins(lof_columns(feats[n], cfg, FPS), cfg.bins)
            cuts, lats = decide(a, cfg, FPS, snaps, fb=fb17)
        return score(cuts, allrecs[n][1], allrecs[n][2], len(a)), list(lats or []), cuts

    res = {c: {n: run(n, c) for n in names} for c in CANDIDATES}
    choice = loo_choices(res, names)
    if LIBRARY:  # streaming == offline for the value the folds chose most
        CHECK_OFFLINE[0] = max(CANDIDATES, key=list(choice.values()).count)
        if CHECK_OFFLINE[0] is not None:
            for n in names:
                run(n, CHECK_OFFLINE[0])
            print(f"streaming == offline cuts on all {len(names)} recordings at "
                  f"{label(CHECK_OFFLINE[0])}")
    loo = {n: res[choice[n]][n] for n in names}
    base = res[None]
    sets = sorted({group(n) for n in names}, key=["cmu", "cmu02", "hdm", "fresh",
                                                  "fresh2"].index)

    if LIBRARY:
        print("round 14: the library's root speeds (LOFConfig.root_speed_max, body scales/s)")
    if lof_only:
        print("round 13: pelvis columns in the LOF only (localisation, contrast and novelty on "
              "the defaults' columns); replay == library checked on every recording")
    print(f"{len(names)} labelled recordings; every candidate, all recordings (not LOO)")
    print("| candidate | pooled F1 | " + " | ".join(sets) + " | below 0.4 | latency median |")
    print("|---|---|" + "---|" * len(sets) + "---|---|")
    for c in CANDIDATES:
        _row(label(c), res[c], names, sets)
    print("\nleave-one-out: each recording scored with the candidate chosen on the other "
          f"{len(names) - 1}")
    print("| detector | pooled F1 | " + " | ".join(sets) + " | below 0.4 | latency median |")
    print("|---|---|" + "---|" * len(sets) + "---|---|")
    b = _row(f"defaults ({label(None)})", base, names, sets)
    m = _row("LOO choice", loo, names, sets)
    counts = {label(c): sum(v == c for v in choice.values()) for c in CANDIDATES}
    print("\nchosen: " + ", ".join(f"{k} {v}x" for k, v in counts.items() if v))
    verdict(names, base, loo, b, m, lambda n: label(choice[n]))


def verdict(names, base, loo, b, m, chose):
    """Print each recording's defaults -> LOO figures (``chose(name)``: the label of its
    fold's choice) and the declared rule of rounds 12-16 on the rows ``b`` and ``m``."""
    print("\nper recording: defaults -> LOO (its choice; F1, cuts, correct of true)")
    for n in names:
        print(f"  {n:26s} {group(n):6s} {base[n][0]['f1']:.2f} -> {loo[n][0]['f1']:.2f} "
              f"({chose(n)})  cuts {base[n][0]['n']} -> {loo[n][0]['n']}, correct "
              f"{base[n][0]['tp']} -> {loo[n][0]['tp']} of {base[n][0]['n_true']}")
    sets = list(b["sets"])
    ok = (m["pooled"] >= b["pooled"] + 0.02,
          all(m["sets"][s] >= b["sets"][s] for s in sets),
          m["below"] <= b["below"], m["latency"] <= 2.5)
    print(f"\nrule: pooled +0.02 {ok[0]} ({b['pooled']:.3f} -> {m['pooled']:.3f}); no set lower "
          f"{ok[1]}; below {FLOOR} not more {ok[2]} ({b['below']} -> {m['below']}); median "
          f"latency {m['latency']:.2f} s <= 2.5 s {ok[3]} -> "
          + ("ADOPT (needs the library option)" if all(ok) else "do not adopt"))


def _row(name, h, names, sets):
    pf = pooled(h, names)[0]
    per = {s: float(np.mean([h[n][0]["f1"] for n in names if group(n) == s])) for s in sets}
    below = sum(h[n][0]["f1"] < FLOOR for n in names)
    lat = float(np.median([x for n in names for x in h[n][1]])) / FPS
    print(f"| {name} | {pf:.3f} | " + " | ".join(f"{per[s]:.3f}" for s in sets)
          + f" | {below} | {lat:.2f} s |")
    return dict(pooled=pf, sets=per, below=below, latency=lat)


if __name__ == "__main__":
    main()
