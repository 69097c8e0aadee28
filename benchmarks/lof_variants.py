"""Variants of the streaming LOF detector that were measured and not adopted (issue 3).

Every choice is made on CMU 86_01 and 14_14 only ("train"); the other recordings of
``benchmarks/lof_accuracy.py`` (14_20 and the two CMU 02 single-action sequences) are printed
as "held-out" for information, never for choosing. Scores: F1 with the label window widened
by 0.5 s (flat +-0.5 s without a window) and with a flat 1 s tolerance, as in lof_accuracy.

1. Novelty LOF (causal): each new window is scored against a reference set of PAST windows
   whose centres are at least ``exclusion`` frames older (so windows overlapping it are not
   its neighbours), the reference's own LOF computed within the reference (scikit-learn's
   ``novelty=True`` semantics). The curve rises as soon as a window holds the new action, so
   it could cut with about 1 s of latency instead of 3.4 s. Two decision rules on that curve:
   "onset" (first window above a robust threshold, the cut at the largest before/after
   histogram contrast in that window, re-armed when the curve falls back) and "peak" (the
   library's Douglas-Peucker peak rule, the cut at the half-rise point before the peak).
2. Cut localisation by before/after histogram contrast with sub-windows of L frames and a
   search radius r around the peak window's centre, applied to the default detector's cuts
   (centre rule); chosen by train F1, ties broken by the mean absolute error of the matched
   cuts (1 s tolerance) on train. The library implements L = window (``LOFConfig.refine_s`` is
   r) and also keeps cut frames ``min_gap`` apart, which this table does not.
3. Re-tuning the symmetric detector (with localisation): bins x window x k, then delay x
   floor x threshold. The train F1 of neighbouring grid points differs by one or two of the
   11 true cuts, so the chosen point maximizes its train F1 averaged with its grid neighbours
   (one step along each axis), not the isolated best. The grids were first run on the 8 bone
   angles and chose the defaults; they are printed here on the adopted 17 features (part 4),
   the defaults marked.
4. Features, every other default held: the paper's 8 bone angles alone, or with each bone's
   inclination from the up axis for a set of bones decided before measuring (all 9 bones;
   the spine; the spine and the 4 proximal limb bones; the 8 limb bones). Adopted: all 9,
   which ties the limb set for the best train F1 and is the complete, rule-free set.

5. The decision for short actions (the current defaults): the recordings gained nine HDM05
   joins of five classes (2-7 s actions, abrupt joins), on which the detector of parts 1-4 was
   mostly silent. Choice on 86_01 and hdm_bd_0 only ("train" of this part; parts 1-4 used
   86_01 and 14_14): a grid over window x k x delay with the absolute LOF floor removed (1.0)
   and the confirming before/after contrast (``min_contrast`` x ``contrast_s``), each point
   scored by its train F1 averaged with its grid neighbours, chosen among the points whose
   median train latency meets the 2.5 s goal (a 2 s delay scores higher on train at 2.8 s);
   the held-out means are per set (cmu = 14_14 and 14_20, cmu02, hdm without hdm_bd_0).
   ``--part 5`` runs only this part.

6. Decisions that scale with the data (issue 11, round 2; nothing adopted): the library's
   LOF buffer is recorded after every window and its causal decision replayed in Python
   (``benchmarks/_lof_replay.py``; the replay is checked to give the library's cuts on every
   recording first), with one extra rule at a time: the robust z-score over the recent N s
   instead of the whole buffer, a second window scale that must support the cut, k as a
   neighbourhood span in seconds (k = span / step), the confirming contrast again at a second
   length, a longer delay (over the latency goal: it would need emit-early-and-withdraw), a
   novelty test of the whole current segment with a minimum segment duration. Choice on a NEW
   pair, fixed before any part-6 figure: 02_walk_punch_sword_wash (the CMU 02 set fails) and
   hdm_bk_0; every other recording, 86_01 and hdm_bd_0 included, is held out, and each
   family winner (and their combination) is scored once on it. Diagnoses: the LOF curve's own
   ceiling (every peak, no threshold: how many true cuts any decision could find) and what
   happens at a CMU 02 join. ``--part 6`` runs only this part (about a minute, Pelt's share).

7. Round 4 (issue 11): part 6's families again, on the speed-histogram curve that round 3
   (``benchmarks/lof_curves.py``) made the default, chosen on a FRESH pair declared before
   any round-4 figure, ``TRAIN_7`` = 14_14 + hdm_dg_0; the 12 other recordings are held out
   and each family winner (and their combination) is scored once. The adoption rule, fixed in
   ``part6(verdict=True)`` before the first run, is applied and printed. Adopted: the segment
   novelty check at 0.15 (``LOFConfig.novelty``; "defaults" here is pinned to
   ``novelty = 0`` so the table reproduces). That family's held-out figure had been seen
   once, in round 3, after its adoption (novelty 0.2 on round 3's held-out set): a selection
   bias this pair does not remove. ``--part 7`` runs only this part (under a minute).

Parts 1 and 2 were measured on the paper's 8 bone angles, before part 4, and are kept so;
parts 1-4 run with today's defaults where they say "defaults".

Parts 1-4 are a research script in numpy (slow, obvious code, no kernels); part 5 runs the
library's detector, part 6 a replay of it. Run:
.venv/bin/python benchmarks/lof_variants.py [--part 5 | --part 6 | --part 7]
"""

from __future__ import annotations

import itertools
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from lof_accuracy import FPS, features, lof_cuts, recordings  # noqa: E402

from streamseg._kernels.peaks import peak_windows  # noqa: E402
from streamseg.config import LOFConfig  # noqa: E402
from streamseg.evaluation.datasets import (  # noqa: E402
    CMU02_MULTI_ACTION_SEQUENCES,
    CMU02_SEQUENCES,
)
from streamseg.evaluation.metrics import cut_scores, match_cuts  # noqa: E402
from streamseg.offline.lof import window_histograms  # noqa: E402

TRAIN = ("86_01", "14_14")
BINS = LOFConfig().bins  # the histograms the default detector uses


def f1s(cuts, truth, windows):
    half = int(0.5 * FPS)
    win = cut_scores(cuts, truth, windows=windows, tolerance=None if windows else half,
                     margin=half if windows else 0)
    return win["f1"], cut_scores(cuts, truth, tolerance=int(FPS))["f1"]


def cosine_distances(a, b):
    na, nb = np.sqrt((a * a).sum(1)), np.sqrt((b * b).sum(1))
    return np.clip(1 - (a @ b.T) / np.maximum(np.outer(na, nb), 1e-300), 0, 2)


def contrast_curve(angles, length):
    """1 - cos between the count histograms of [f - L, f) and [f, f + L), NaN where undefined."""
    n = len(angles)
    valid = np.isfinite(angles).all(1)
    b = np.clip(np.floor(np.nan_to_num(angles) * BINS / np.pi).astype(int), 0, BINS - 1)
    onehot = np.zeros((n, 8 * BINS))
    for a in range(8):
        onehot[np.arange(n), a * BINS + b[:, a]] = valid
    p = np.vstack([np.zeros(8 * BINS), np.cumsum(onehot, 0)])
    out = np.full(n + 1, np.nan)
    f = np.arange(length, n - length + 1)
    left, right = p[f] - p[f - length], p[f + length] - p[f]
    den = np.sqrt((left * left).sum(1) * (right * right).sum(1))
    out[f] = 1 - (left * right).sum(1) / np.maximum(den, 1e-300)
    return out


def argmax_near(curve, centre, radius, length, n):
    lo, hi = max(length, centre - radius), min(n - length, centre + radius)
    seg = curve[lo:hi + 1] if hi >= lo else np.array([])
    return lo + int(np.nanargmax(seg)) if np.isfinite(seg).any() else centre


# --- 1. novelty LOF ------------------------------------------------------------------------


def _reference_stats(d, k):
    """k-distance and lrd of every point of a reference set, within the set."""
    kk = min(k, d.shape[0] - 1)
    dm = d.copy()
    np.fill_diagonal(dm, np.inf)
    idx = np.argpartition(dm, kk - 1, axis=1)[:, :kk]
    nd = np.take_along_axis(dm, idx, 1)
    kd = nd.max(1)
    return kd, 1.0 / (np.maximum(nd, kd[idx]).mean(1) + 1e-10)


def novelty_curve(counts, centres, k, exclusion, min_ref=3):
    """LOF of each window against the earlier windows at least ``exclusion`` frames older."""
    d = cosine_distances(counts, counts)
    y = np.full(len(counts), np.nan)
    cache = {}
    for i in range(len(counts)):
        r = min(i, int(np.searchsorted(centres, centres[i] - exclusion, side="right")))
        if r < min_ref:
            continue
        if r not in cache:
            cache[r] = _reference_stats(d[:r, :r], k)
        kd, lrd = cache[r]
        kk = min(k, r - 1)
        o = np.argsort(d[i, :r], kind="stable")[:kk]
        lrd_q = 1.0 / (np.maximum(d[i, o], kd[o]).mean() + 1e-10)
        y[i] = (lrd[o] / lrd_q).mean()
    return y


def onset_cuts(angles, centres, y, window, contrast, n_mads, floor):
    cuts, lats, armed, hist = [], [], True, []
    for i in np.flatnonzero(np.isfinite(y)):
        hist.append(y[i])
        h = np.array(hist)
        med = np.median(h)
        thr = max(floor, med + n_mads * 1.4826 * np.median(np.abs(h - med)))
        if not armed:
            armed = y[i] < thr
            continue
        if y[i] >= thr:
            end = int(centres[i]) - window // 2 + window
            lo = max(end - window, (cuts[-1] + int(FPS)) if cuts else 0)
            f = argmax_near(contrast, (lo + end) // 2, (end - lo) // 2, window // 2, len(angles))
            cuts.append(f)
            lats.append(max(end - 1, f + window // 2 - 1) - f)
            armed = False
    return cuts, lats


def peak_cuts(centres, y, step, delay_s, n_mads, floor):
    ok = np.flatnonzero(np.isfinite(y))
    yy, cc = y[ok], centres[ok]
    delay = int(round(delay_s * FPS / step))
    cuts, lats = [], []
    for p in peak_windows(yy, delay, 0.1, n_mads, floor, int(round(FPS / step))):
        j = p
        while j > 0 and yy[j - 1] < yy[j]:
            j -= 1
        q = p
        while q > j and yy[q - 1] >= yy[j] + 0.5 * (yy[p] - yy[j]):
            q -= 1
        cuts.append(int(cc[q]))
        lats.append(int(cc[min(p + delay, len(cc) - 1)]) - int(cc[q]))
    return cuts, lats


def novelty_table(recs):
    rows = []
    for window_s, k, excl in itertools.product((1.5, 2.0), (5, 10), (0.5, 1.0)):
        w = int(window_s * FPS)
        step = w // 10
        curves = {}
        for name, (a, _, _) in recs.items():
            counts, centres, _ = window_histograms(a, w, step, BINS, w // 2)
            curves[name] = (centres, novelty_curve(counts, centres, k, int(excl * w)))
        contrast = {name: contrast_curve(a, w // 2) for name, (a, _, _) in recs.items()}
        for n_mads, floor in itertools.product((0.0, 1.5, 3.0), (1.5, 2.0, 3.0)):
            res = {}
            for name, (a, truth, windows) in recs.items():
                centres, y = curves[name]
                cuts, lats = onset_cuts(a, centres, y, w, contrast[name], n_mads, floor)
                res[name] = f1s(cuts, truth, windows) + (np.median(lats) if lats else np.nan,)
            rows.append(("onset", f"W={window_s} k={k} excl={excl}W mads={n_mads} "
                                  f"floor={floor}", res))
        for delay_s, n_mads, floor in itertools.product((0.5, 1.0, 1.5), (0.0, 1.5),
                                                        (1.3, 2.0)):
            res = {}
            for name, (_, truth, windows) in recs.items():
                centres, y = curves[name]
                cuts, lats = peak_cuts(centres, y, step, delay_s, n_mads, floor)
                res[name] = f1s(cuts, truth, windows) + (np.median(lats) if lats else np.nan,)
            rows.append(("peak", f"W={window_s} k={k} excl={excl}W delay={delay_s} "
                                 f"mads={n_mads} floor={floor}", res))
    return rows


# --- 2. localisation -------------------------------------------------------------------------


def localisation_table(recs):
    base = {name: lof_cuts(a, LOFConfig(refine_s=0.0, inclinations=False), True)[0]
            for name, (a, _, _) in recs.items()}
    rows = []
    window = LOFConfig().frames(FPS)["window"]
    for length, radius in [(None, 0)] + list(itertools.product((60, 120, 180, window),
                                                               (24, 48, 96, 120))):
        res, errors = {}, []
        for name, (a, truth, windows) in recs.items():
            cuts = base[name]
            if length is not None:
                c = contrast_curve(a, length)
                cuts = [argmax_near(c, f, radius, length, len(a)) for f in cuts]
            res[name] = f1s(cuts, truth, windows)
            if name in TRAIN:
                srt = np.sort(cuts)
                errors += [abs(int(srt[i]) - int(truth[j]))
                           for i, j in match_cuts(cuts, truth, tolerance=int(FPS))]
        label = "centre rule" if length is None else f"L={length} r={radius}"
        rows.append((label, float(np.mean(errors)), res))
    return rows


def smoothed_grid(recs, axes, make):
    """Train F1 of every grid point and its average with its one-step grid neighbours."""
    keys = list(axes)
    score = {}
    for point in itertools.product(*axes.values()):
        cfg = make(dict(zip(keys, point)))
        score[point] = {name: f1s(lof_cuts(a, cfg, True)[0], truth, windows)
                        for name, (a, truth, windows) in recs.items()}
    train = {p: np.mean([r[n][0] for n in TRAIN]) for p, r in score.items()}
    return score, train, neighbour_mean(train, axes)


def neighbour_mean(train, axes):
    """Each grid point's train score averaged with its one-step neighbours along each axis."""
    keys = list(axes)
    smooth = {}
    for p in train:
        idx = [list(axes[k]).index(v) for k, v in zip(keys, p)]
        vals = [train[p]]
        for ax in range(len(keys)):
            for d in (-1, 1):
                j = list(idx)
                j[ax] += d
                if 0 <= j[ax] < len(axes[keys[ax]]):
                    vals.append(train[tuple(axes[keys[i]][j[i]] for i in range(len(keys)))])
        smooth[p] = float(np.mean(vals))
    return smooth


TRAIN_5 = ("86_01", "hdm_bd_0")


def part5():
    """The short-action decision grid (part 5 of the module docstring)."""
    from lof_accuracy import set_of

    raw = {k: v for k, v in recordings().items() if k not in CMU02_MULTI_ACTION_SEQUENCES}
    recs = {k: (features(r, True), t, w) for k, (r, t, w) in raw.items()}
    d = LOFConfig()
    axes = {"window_s": (1.25, 1.75, 2.25), "k": (5, 8, 10), "delay_s": (1.0, 1.5, 2.0),
            "min_contrast": (0.1, 0.15, 0.2), "contrast_s": (1.5, 2.0, 3.0)}
    keys = list(axes)
    score, lat = {}, {}
    for point in itertools.product(*axes.values()):
        cfg = LOFConfig(**dict(zip(keys, point)))
        score[point], train_lat = {}, []
        for n, (a, t, w) in recs.items():
            cuts, latency = lof_cuts(a, cfg, True)
            score[point][n] = f1s(cuts, t, w)[0]
            if n in TRAIN_5:
                train_lat += latency
        lat[point] = float(np.median(train_lat)) / FPS if train_lat else float("nan")
    train = {p: np.mean([r[n] for n in TRAIN_5]) for p, r in score.items()}
    smooth = neighbour_mean(train, axes)

    def held(res, set_name):
        v = [f for n, f in res.items() if set_of(n) == set_name and n not in TRAIN_5]
        return float(np.mean(v))

    now = tuple(getattr(d, k) for k in keys)
    # the latency goal (median <= 2.5 s) is a requirement, so it bounds the choice: among the
    # points whose median latency on the train pair meets it, the best smoothed train F1
    ok = [p for p in score if lat[p] <= 2.5]
    chosen = max(ok, key=lambda q: smooth[q])
    print("5. short-action decision grid, train = " + " + ".join(TRAIN_5) + " (streaming F1); "
          "held-out means per set; lat = median latency on train, s")
    print(f"  {'point':62s} smooth  train  lat   cmu  cmu02  hdm  worst")
    best = sorted(score, key=lambda q: -smooth[q])[:5]
    for p in best + [q for q in sorted(ok, key=lambda q: -smooth[q])[:3] if q not in best]:
        res = score[p]
        tag = " <- chosen (defaults)" if p == chosen == now else " <- chosen" \
            if p == chosen else " <- defaults" if p == now else ""
        print(f"  {dict(zip(keys, p))!s:62s} {smooth[p]:5.2f}  {train[p]:5.2f} {lat[p]:4.2f} "
              f"{held(res, 'cmu'):4.2f}  {held(res, 'cmu02'):4.2f}  {held(res, 'hdm'):4.2f}  "
              f"{min(res.values()):4.2f}{tag}")
    for ax in keys:  # one axis at a time through the defaults
        for v in axes[ax]:
            p = tuple(v if k == ax else getattr(d, k) for k in keys)
            res = score[p]
            print(f"  {ax}={v!s:6s} train {train[p]:.2f} smooth {smooth[p]:.2f}  held cmu "
                  f"{held(res, 'cmu'):.2f} cmu02 {held(res, 'cmu02'):.2f} hdm "
                  f"{held(res, 'hdm'):.2f}")


# --- 6. decisions that scale with the data (issue 11, round 2) -------------------------------

#: chosen before any part-6 figure was seen: the first CMU 02 join (the set that fails, on
#: precision) and the first HDM05 join of an actor the part-5 pair did not use. Every other
#: recording, 86_01 and hdm_bd_0 included, is held out.
TRAIN_6 = ("02_walk_punch_sword_wash", "hdm_bk_0")

#: round 4 (issue 11): the part-6 families again, on the speed-histogram curve (the defaults
#: since ``benchmarks/lof_curves.py``), chosen on a FRESH pair declared before any round-4
#: figure: 14_14 and hdm_dg_0, neither a train recording of rounds 2 and 3. Every other
#: recording (86_01, 14_20, both CMU 02 joins, the 8 other HDM05 joins) is held out and each
#: family winner is scored on it once. Round 3 saw, after its adoption, that "segment novelty
#: 0.2" would score 0.74 held out on TRAIN_6's held-out set: that number was seen before this
#: round, so only the choice this pair makes counts.
TRAIN_7 = ("14_14", "hdm_dg_0")


def part6(train=TRAIN_6, verdict=False):
    """Candidate rules replayed on the library's LOF buffer (``_lof_replay``), chosen on ``train``
    (TRAIN_6 in round 2, TRAIN_7 in round 4: ``part7``).

    Families, each on top of the current defaults: the robust z-score over the recent N s of
    LOF (not the whole buffer); a second window scale that must support the cut (the default
    scale proposes, a longer or shorter one confirms); k as a neighbourhood span in seconds
    (k = span / step, with the step varied); a novelty test of the whole current segment against
    the after side with a minimum segment duration. Within a family the point with the best
    train F1 averaged with its grid neighbours wins among those whose median train latency is
    <= 2.5 s; the family winners and their combination are then scored once on the held-out
    recordings.

    With ``verdict`` the rule fixed before round 4's first run is applied and printed: a
    candidate (a family winner, or the combination) is adopted only if (1) its train F1 beats
    the defaults' on ``train``; held out, (2) the pooled F1 (all held-out cuts added up) beats
    the defaults', (3) no set's mean F1 (cmu, cmu02, hdm) is lower and the held-out mean is
    higher; (4) the median latency over all recordings is <= 2.5 s. The longer delay is not
    eligible (over the latency goal). When several pass, the train pair's choice (the highest
    smoothed train F1) is adopted. Returns the adopted candidate's label or None.
    """
    from dataclasses import replace

    from _lof_replay import decide, merge_causal, snapshots
    from lof_accuracy import set_of

    raw = {k: v for k, v in recordings().items() if k not in CMU02_MULTI_ACTION_SEQUENCES}
    recs = {k: (np.ascontiguousarray(features(r, True)), t, w) for k, (r, t, w) in raw.items()}
    # the defaults before round 4's novelty check (its table is reproducible after adoption)
    d = LOFConfig(novelty=0.0)
    snap_cache = {}

    def snaps(name, cfg):
        key = (name, cfg.window_s, cfg.step_s, cfg.k, cfg.bins)
        if key not in snap_cache:
            snap_cache[key] = snapshots(recs[name][0], cfg, FPS)
        return snap_cache[key]

    def run(names, cfg=d, confirm_w=None, union_w=None, **kw):
        out, lats = {}, []
        for n in names:
            a, t, w = recs[n]
            extra = dict(kw)
            if "adaptive_k" in extra:
                al, km = extra["adaptive_k"]
                extra["adaptive_k"] = ({k: snaps(n, replace(cfg, k=k)) for k in
                                        range(cfg.k, km + 1)}, al, km)
            if confirm_w is not None:
                extra["confirm"] = snaps(n, replace(cfg, window_s=confirm_w))
            cuts, lat = decide(a, cfg, FPS, snaps(n, cfg), **extra)
            if union_w is not None:
                c2 = replace(cfg, window_s=union_w)
                cuts, lat = merge_causal([(cuts, lat), decide(a, c2, FPS, snaps(n, c2))],
                                         int(cfg.min_gap_s * FPS))
            out[n] = f1s(cuts, t, w)[0]
            half = int(0.5 * FPS)
            counts[n] = cut_scores(cuts, t, windows=w, tolerance=None if w else half,
                                   margin=half if w else 0)
            lats += lat
        return out, (float(np.median(lats)) / FPS if lats else float("nan"))

    counts = {}  # the last run's cut_scores per recording (pooled counts of the table)

    # the replay must be the library's decision before it can stand for variants of it
    for n, (a, _, _) in recs.items():
        assert decide(a, d, FPS, snaps(n, d))[0] == lof_cuts(a, d, True)[0], n
        # and the library's novelty check (LOFConfig.novelty) is the replay's
        lib = LOFConfig()
        assert decide(a, lib, FPS, snaps(n, lib))[0] == lof_cuts(a, lib, True)[0], n
    held_names = [n for n in recs if n not in train]
    r_fps = int(FPS)
    families = {
        "recent z-score": ({"recent_s": (10.0, 20.0, 40.0), "mads": (1.0, 1.5, 2.0, 3.0)},
                           lambda v: dict(recent_s=v["recent_s"], mads=v["mads"])),
        "second scale confirms": (
            {"confirm_w": (1.25, 2.5, 3.5), "confirm_r": (0.5, 1.0),
             "confirm_mads": (0.0, 1.0, 2.0)},
            lambda v: dict(confirm_w=v["confirm_w"], confirm_r=int(v["confirm_r"] * r_fps),
                           confirm_mads=v["confirm_mads"])),
        "k as a span": ({"step_s": (0.1, 0.2, 0.3), "span_s": (0.6, 1.0, 1.6, 2.4)},
                        lambda v: dict(cfg=replace(d, step_s=v["step_s"], k=max(
                            2, int(round(v["span_s"] / v["step_s"])))))),
        "contrast at a second scale": (
            {"contrast2_s": (1.0, 3.0, 4.0), "min_contrast2": (0.1, 0.15, 0.2, 0.25)},
            lambda v: dict(contrast2=int(v["contrast2_s"] * r_fps),
                           min_contrast2=v["min_contrast2"])),
        # short actions need short windows, long ones tolerate noise: cuts of either scale
        "union of two scales": ({"union_w": (1.0, 1.25, 2.25, 3.0)},
                                lambda v: dict(union_w=v["union_w"])),
        # k from the stream's own segments: k_max caps it
        "k from segment length": (
            {"alpha": (0.25, 0.5, 0.75, 1.0), "k_max": (8, 12, 20)},
            lambda v: dict(adaptive_k=(v["alpha"], v["k_max"]))),
        # the part-5 grid itself, chosen again on the new pair: are the defaults pair-specific?
        "part-5 grid on this pair": (
            {"window_s": (1.25, 1.75, 2.25), "k": (5, 8, 10), "delay_s": (1.0, 1.5, 2.0),
             "min_contrast": (0.1, 0.15, 0.2), "contrast_s": (1.5, 2.0, 3.0)},
            lambda v: dict(cfg=replace(d, **v))),
        # later evidence: over the latency goal, so it would need emit-early-and-withdraw
        "longer delay (no lat. goal)": ({"delay_s": (1.5, 2.0, 2.5, 3.0)},
                                        lambda v: dict(cfg=replace(d, delay_s=v["delay_s"]))),
        "segment novelty": ({"novelty": (0.1, 0.15, 0.2, 0.3), "min_seg_s": (0.0, 2.0, 3.0)},
                            lambda v: dict(novelty=v["novelty"],
                                           min_seg=int(v["min_seg_s"] * r_fps))),
    }
    base_tr, base_lat = run(train)
    base = float(np.mean(list(base_tr.values())))
    print("6. decisions that scale with the data, train = " + " + ".join(train)
          + " (streaming F1, label window + 0.5 s); replay == library checked on every "
          "recording")
    print(f"  defaults: train {base:.2f} ({', '.join(f'{v:.2f}' for v in base_tr.values())}), "
          f"median train latency {base_lat:.2f} s")
    winners, smooth_of = {}, {}
    for fam, (axes, make) in families.items():
        score, lat = {}, {}
        for point in itertools.product(*axes.values()):
            v = dict(zip(axes, point))
            res, lat[point] = run(train, **make(v))
            score[point] = float(np.mean(list(res.values())))
        smooth = neighbour_mean(score, axes)
        ok = [p for p in score if lat[p] <= 2.5 or "no lat." in fam]
        best = max(ok, key=lambda p: (smooth[p], score[p])) if ok else None
        print(f"  {fam}: best 4 of {len(score)} by smoothed train F1"
              + ("" if "no lat." in fam else " (latency <= 2.5 s)"))
        for p in sorted(ok, key=lambda p: -smooth[p])[:4]:
            print(f"    {dict(zip(axes, p))!s:60s} smooth {smooth[p]:.2f} train "
                  f"{score[p]:.2f} lat {lat[p]:.2f}{' <- family winner' if p == best else ''}")
        if best is not None:
            winners[fam] = make(dict(zip(axes, best)))
            smooth_of[fam] = smooth[best]
    combo = {}
    for fam, kw in winners.items():  # the winners that beat the defaults on train, together
        if "no lat." in fam or "grid" in fam:  # a latency trade, a re-tuning: not rules
            continue
        if np.mean(list(run(train, **kw)[0].values())) > base:
            combo.update(kw)
    cands = {"defaults": {}, **winners, "all winners combined": combo}
    by_set = {s: [n for n in held_names if set_of(n) == s] for s in ("cmu", "cmu02", "hdm")}
    print("\n  candidates, scored once on the held-out recordings (F1, held-out mean per set: "
          + "; ".join(f"{s} = {', '.join(v) if len(v) < 4 else f'{len(v)} joins'}"
                      for s, v in by_set.items())
          + f"; worst over all {len(recs)} recordings; median latency over all, s; pooled F1 "
          "from the held-out cuts added up)")
    print(f"  {'candidate':28s} train   cmu  cmu02   hdm  held  worst (all)                   lat  "
          "held-out pooled: cuts / correct / true    F1")
    table, per_rec = {}, {}
    for label, kw in cands.items():
        tr, _ = run(train, **kw)
        he, lat = run(list(recs), **kw)
        per_rec[label] = he
        mean = {s: float(np.mean([he[n] for n in v])) for s, v in by_set.items()}
        worst = min((he[n], n) for n in recs)
        pred, tp, true = (sum(counts[n][k] for n in held_names)
                          for k in ("n_pred", "tp", "n_true"))
        pooled = 2 * tp / (pred + true) if pred + true else 0.0
        table[label] = dict(train=float(np.mean(list(tr.values()))), sets=mean, lat=lat,
                            held=float(np.mean([he[n] for n in held_names])), pooled=pooled)
        print(f"  {label:28s} {table[label]['train']:5.2f}  {mean['cmu']:4.2f}  "
              f"{mean['cmu02']:4.2f}  {mean['hdm']:4.2f}  {table[label]['held']:4.2f}  "
              f"{worst[0]:4.2f} {worst[1]:24s} {lat:4.2f}  {pred:3d} / {tp:2d} / {true}"
              f"            {pooled:4.2f}")
    if not verdict:
        return None
    d0 = table["defaults"]
    passed = []
    for label, t in table.items():
        if label == "defaults" or "no lat." in label:
            continue
        why = [w for w, bad in (
            ("train not better", t["train"] <= d0["train"]),
            ("pooled not better", t["pooled"] <= d0["pooled"]),
            ("held-out mean not better", t["held"] <= d0["held"]),
            *((f"{s} worse", t["sets"][s] < d0["sets"][s]) for s in by_set),
            ("median latency > 2.5 s", not t["lat"] <= 2.5)) if bad]
        print(f"  rule check {label:28s} " + ("passes" if not why else "; ".join(why)))
        if not why:
            passed.append(label)
    if not passed:
        print("  adopted: none (the defaults stay)")
        return None
    # the combination has no grid of its own: its train F1 stands for its smoothed one
    chosen = max(passed, key=lambda q: smooth_of.get(q, table[q]["train"]))
    print(f"  adopted by the rule fixed beforehand: {chosen} {cands[chosen]}")
    print(f"  per recording, F1: defaults -> {chosen} (train recordings marked *)")
    for n in recs:
        print(f"    {n + (' *' if n in train else ''):28s} {per_rec['defaults'][n]:4.2f} -> "
              f"{per_rec[chosen][n]:4.2f}")
    return chosen


def part7():
    """Round 4: part 6's families on the speed-histogram curve, chosen on TRAIN_7."""
    return part6(TRAIN_7, verdict=True)


def part6_ceiling():
    """How many true cuts any decision on this LOF curve could find (part 6, diagnosis; pooled
    over all 14 recordings, not used for choosing): every peak of the curve, no threshold, no
    contrast, with the 1 s gap and with a 0.2 s gap."""
    from dataclasses import replace

    from _lof_replay import decide, snapshots

    raw = {k: v for k, v in recordings().items() if k not in CMU02_MULTI_ACTION_SEQUENCES}
    d = LOFConfig()
    every = replace(d, threshold_mads=0.0, min_score=0.0, min_contrast=0.0, novelty=0.0)
    half = int(0.5 * FPS)
    print("\n6b. the LOF curve's own ceiling, pooled over all 14 recordings: cuts / correct / "
          "true (label window + 0.5 s)")
    for label, cfg in (("defaults", d), ("every peak (1 s gap)", every),
                       ("every peak (0.2 s gap)", replace(every, min_gap_s=0.2))):
        tot = np.zeros(3, dtype=int)
        for r, t, w in raw.values():
            a = np.ascontiguousarray(features(r, True))
            s = cut_scores(decide(a, cfg, FPS, snapshots(a, cfg, FPS))[0], t, windows=w,
                           tolerance=None if w else half, margin=half if w else 0)
            tot += (s["n_pred"], s["tp"], s["n_true"])
        print(f"  {label:24s} {tot[0]:4d} / {tot[1]:3d} / {tot[2]}")


def part6_joins():
    """Why the CMU 02 joins cost precision: what happens at a join (part 6, diagnosis).

    For each CMU 02 sequence, the largest one-frame step of the mean joint position at the join
    against the largest within 1 s of it (the joined clips do not meet in the same pose), and
    the mean joint speed in the 1 s before and after each join (clips begin and end at rest).
    On the train sequence only, the default detector's cuts beside Pelt's (pen 80).
    """
    from lof_accuracy import Pelt

    raw = recordings()
    print("\n6c. the CMU 02 joins: one-frame pose step at the join / largest step within 1 s of "
          "it (mean joint, skeleton units); mean joint speed 1 s before | after the join")
    for name in CMU02_SEQUENCES:
        r, truth, _ = raw[name]
        step = np.linalg.norm(np.diff(r.positions, axis=0), axis=2).mean(1)  # step[f]: f->f+1
        parts = []
        for t in truth:
            near = max(step[t - 121:t - 2].max(), step[t:t + 120].max())
            before, after = step[t - 120:t - 1].mean() * FPS, step[t:t + 120].mean() * FPS
            parts.append(f"{t}: {step[t - 1]:.3f}/{near:.3f}, speed {before:.2f} | {after:.2f}")
        print(f"  {name:26s} median step {np.median(step):.4f}; " + "; ".join(parts))
    name = TRAIN_6[0]
    r, truth, _ = raw[name]
    a = np.ascontiguousarray(features(r, True))
    lof = lof_cuts(a, LOFConfig(), True)[0]
    print(f"  {name} (train): joins {list(truth)}; LOF defaults {lof}; Pelt pen 80 "
          f"{Pelt(a).cuts(80)}")


def _fmt(res, names):
    return " ".join(f"{res[n][0]:4.2f}/{res[n][1]:4.2f}" for n in names)


def main():
    t0 = time.perf_counter()
    if "--part" in sys.argv and sys.argv[sys.argv.index("--part") + 1] == "7":
        part7()
        print(f"\n[{time.perf_counter() - t0:.0f} s]")
        return
    if "--part" in sys.argv and sys.argv[sys.argv.index("--part") + 1] == "6":
        part6()
        part6_ceiling()
        part6_joins()
        print(f"\n[{time.perf_counter() - t0:.0f} s]")
        return
    part5()
    if "--part" in sys.argv and sys.argv[sys.argv.index("--part") + 1] == "5":
        print(f"\n[{time.perf_counter() - t0:.0f} s]")
        return
    print()
    raw = {k: v for k, v in recordings().items() if k not in CMU02_MULTI_ACTION_SEQUENCES}
    full = {k: (features(r, True), t, w) for k, (r, t, w) in raw.items()}
    recs = {k: (a[:, :8], t, w) for k, (a, t, w) in full.items()}  # the paper's 8 angles
    names = list(recs)
    held = [n for n in names if n not in TRAIN]
    print("F1 0.5 s / 1 s per recording: " + ", ".join(names))
    print("train = mean F1 (0.5 s) on " + " + ".join(TRAIN) + "; held = mean on the others\n")

    default = {name: f1s(lof_cuts(a, LOFConfig(), True)[0], truth, windows)
               for name, (a, truth, windows) in full.items()}
    tr, he = np.mean([default[n][0] for n in TRAIN]), np.mean([default[n][0] for n in held])
    print(f"{'adopted: symmetric LOF, defaults':58s} train {tr:.2f} held {he:.2f}  "
          f"{_fmt(default, names)}  latency ~3.5-3.9 s")

    print("\n4. features (streaming, every other default held):")
    subsets = {"8 bone angles (the paper)": [], "+ 9 inclinations (adopted)": list(range(9)),
               "+ spine inclination": [0], "+ spine, upper arms, thighs": [0, 1, 3, 5, 7],
               "+ 8 limb inclinations": list(range(1, 9))}
    for label, extra in subsets.items():
        res = {}
        for name, (a, truth, windows) in full.items():
            f = np.ascontiguousarray(np.concatenate([a[:, :8], a[:, 8:][:, extra]], axis=1))
            res[name] = f1s(lof_cuts(f, LOFConfig(), True)[0], truth, windows)
        print(f"  {label:30s} train {np.mean([res[n][0] for n in TRAIN]):.2f} "
              f"held {np.mean([res[n][0] for n in held]):.2f}  {_fmt(res, names)}")

    print("\n1. novelty LOF (causal reference of past non-overlapping windows), best 3 of each "
          "rule by train F1:")
    rows = novelty_table(recs)
    for rule in ("onset", "peak"):
        sel = sorted((r for r in rows if r[0] == rule),
                     key=lambda r: -np.mean([r[2][n][0] for n in TRAIN]))[:3]
        for _, label, res in sel:
            lat = np.nanmedian([res[n][2] for n in names])
            print(f"  {rule:5s} {label:50s} train {np.mean([res[n][0] for n in TRAIN]):.2f} "
                  f"held {np.mean([res[n][0] for n in held]):.2f}  {_fmt(res, names)}  "
                  f"median latency {lat:.0f} frames")

    print("\n2. cut localisation on the default detector's streaming cuts (train MAE: mean "
          "|cut - true cut| of matched cuts, frames):")
    for label, mae, res in localisation_table(recs):
        print(f"  {label:14s} train MAE {mae:5.1f}  train {np.mean([res[n][0] for n in TRAIN]):.2f}"
              f" held {np.mean([res[n][0] for n in held]):.2f}  {_fmt(res, names)}")
    print("\n3. re-tuning (streaming, localisation on, 17 features), chosen by train F1 averaged "
          "with the grid neighbours:")
    d = LOFConfig()
    stages = [
        ({"bins": (5, 6, 7, 8, 10), "window_s": (2.0, 2.25, 2.5, 2.75, 3.0), "k": (8, 10, 12)},
         lambda v: LOFConfig(**v)),
        ({"delay_s": (2.0, 2.5, 3.0), "min_score": (1.2, 1.3, 1.5),
          "threshold_mads": (1.0, 1.5, 2.0)},
         lambda v: LOFConfig(bins=d.bins, window_s=d.window_s, k=d.k, **v)),
    ]
    for axes, make in stages:
        score, train, smooth = smoothed_grid(full, axes, make)
        best = sorted(score, key=lambda p: -smooth[p])[:4]
        now = tuple(getattr(d, k) for k in axes)
        for p in best + ([now] if now not in best else []):
            res = score[p]
            tag = " <- defaults" if p == now else ""
            print(f"  {dict(zip(axes, p))!s:58s} smoothed {smooth[p]:.2f} train {train[p]:.2f} "
                  f"held {np.mean([res[n][0] for n in held]):.2f}  {_fmt(res, names)}{tag}")
    print(f"\n[{time.perf_counter() - t0:.0f} s]")


if __name__ == "__main__":
    main()
