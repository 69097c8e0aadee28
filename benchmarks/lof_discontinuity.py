"""A data-discontinuity rule beside the live LOF cuts (issue 11, round 4; a diagnosis, not in
the library).

The rule: when a feature (bone angle or inclination, radians) changes between two consecutive
valid frames faster than ``JUMP_RAD_S``, the data broke (takes concatenated, frames lost), so
cut at that frame at once (latency 0). The bound is physical and fixed before any figure of
this script was seen, not tuned on any recording: the fastest human joint rotation reported is
the humerus' internal rotation when pitching, 7,500-7,700 deg/s (about 134 rad/s; a review of
the kinetic chain in overhand pitching, https://pmc.ncbi.nlm.nih.gov/articles/PMC3445080);
200 rad/s is 1.5 times that.
At 120 Hz it is a jump of 1.67 rad in one frame; below 200 / pi = 64 Hz no jump can reach it
(angles live in [0, pi]), so the rule is silent there.

CAVEAT, read before the table: the CMU 02 and HDM05 sequences are joined clips, their true
cuts ARE such discontinuities (abrupt by construction), so this rule is favoured by exactly
the sets it is scored on; on a natural take (86_01, 14_14, 14_20: people move from one action
to the next) it can only add false cuts (a marker swap, a glitch). Its figures are reported
apart from the library's and say nothing about live transitions.

Scoring: the default detector's live cuts, and those merged with the break cuts in emission
order (``_lof_replay.merge_causal``, 1 s gap: a break is emitted at once, so the LOF cut near
it is the one dropped). In the library a break would also reset the detector's previous cut
(the contrast and novelty sides), which the merge does not model. F1 with the label window +
0.5 s, as ``lof_accuracy``. Run: .venv/bin/python benchmarks/lof_discontinuity.py (about 20 s)
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from _lof_replay import merge_causal  # noqa: E402
from lof_accuracy import FPS, features, lof_cuts, recordings, set_of  # noqa: E402

from streamseg.config import LOFConfig  # noqa: E402
from streamseg.evaluation.datasets import CMU02_MULTI_ACTION_SEQUENCES  # noqa: E402
from streamseg.evaluation.metrics import cut_scores  # noqa: E402

#: rad/s; fixed from the literature before the first run (module docstring)
JUMP_RAD_S = 200.0


def frame_speed(angles, fps):
    """(n,) the fastest feature's change from the previous valid frame, rad/s (0 at frame 0 and
    at NaN frames)."""
    out = np.zeros(len(angles))
    ok = np.isfinite(angles).all(axis=1)
    prev = -1
    for f in range(len(angles)):
        if not ok[f]:
            continue
        if prev >= 0:
            out[f] = np.abs(angles[f] - angles[prev]).max() * fps / (f - prev)
        prev = f
    return out


def break_cuts(angles, fps, bound, gap):
    """Frames where the data breaks (speed over ``bound``), ``gap`` frames apart (first wins):
    causal, each decided on its own frame (latency 0)."""
    cuts = []
    for f in np.flatnonzero(frame_speed(angles, fps) > bound):
        if not cuts or f - cuts[-1] >= gap:
            cuts.append(int(f))
    return cuts


def main():
    t0 = time.perf_counter()
    raw = {k: v for k, v in recordings().items() if k not in CMU02_MULTI_ACTION_SEQUENCES}
    gap, half = int(LOFConfig().min_gap_s * FPS), int(0.5 * FPS)
    print(f"data-discontinuity rule: a feature faster than {JUMP_RAD_S:g} rad/s between two "
          f"frames ({JUMP_RAD_S / FPS:.2f} rad per frame at {FPS:g} Hz) is a cut, latency 0")
    print("CAVEAT: the cmu02 and hdm joins are abrupt by construction; this rule favours them "
          "and says nothing about natural transitions (cmu)\n")
    print("fastest: the largest frame speed farther than 0.5 s from every true cut; at joins: "
          "the largest within 2 frames of each true cut (rad/s)")
    print(f"{'recording':26s} {'set':5s} {'fastest':>8s} {'at joins (rad/s)':34s} breaks "
          f"{'on a true cut':>13s}  F1 LOF -> +breaks")
    rows = {}
    for name, (r, truth, windows) in raw.items():
        a = np.ascontiguousarray(features(r, True))
        speed = frame_speed(a, FPS)
        at_join = [float(speed[max(0, t - 2):t + 3].max()) for t in truth]
        near = np.zeros(len(a), dtype=bool)
        for t in truth:
            near[max(0, t - half):t + half] = True
        brk = break_cuts(a, FPS, JUMP_RAD_S, gap)
        lof, lat = lof_cuts(a, LOFConfig(), True)
        both, both_lat = merge_causal([(lof, lat), (brk, [0] * len(brk))], gap)

        s0, s1 = (cut_scores(c, truth, windows=windows, tolerance=None if windows else half,
                             margin=half if windows else 0) for c in (lof, both))
        rows[name] = (s0, s1, both_lat)
        on_true = sum(1 for b in brk if near[b])
        joins = " ".join(f"{v:.0f}" for v in at_join)
        print(f"{name:26s} {set_of(name):5s} {speed[~near].max():8.0f} {joins:34s} "
              f"{len(brk):6d} {on_true:13d}  {s0['f1']:.2f} -> {s1['f1']:.2f}")
    print("\nper set: mean F1 LOF -> LOF + breaks; pooled cuts / correct / true; median latency s")
    for s in ("cmu", "cmu02", "hdm"):
        names = [n for n in rows if set_of(n) == s]
        f0 = np.mean([rows[n][0]["f1"] for n in names])
        f1 = np.mean([rows[n][1]["f1"] for n in names])
        pooled = [sum(rows[n][i][k] for n in names) for i in (0, 1)
                  for k in ("n_pred", "tp", "n_true")]
        lats = [x for n in names for x in rows[n][2]]
        print(f"  {s:5s} {f0:.3f} -> {f1:.3f}   {pooled[0]}/{pooled[1]}/{pooled[2]} -> "
              f"{pooled[3]}/{pooled[4]}/{pooled[5]}   latency median {np.median(lats) / FPS:.2f}")
    print(f"[{time.perf_counter() - t0:.0f} s]")


if __name__ == "__main__":
    main()
