"""How many actions: criteria for K compared on every labelled recording and the synthetic set.

For each labelled recording (CMU 86_01, 14_14, 14_20, the two CMU 02 joins and the nine HDM05
joins of ``streamseg.evaluation.datasets``; the joins are ABRUPT, not natural transitions)
HACA with the library's defaults (``ACAConfig()``, the daemon's 17 cut features) is fitted
ONCE for K = 2..k_max (``HACA.fit_each``: one fine level, one coarse level per K), and every
criterion picks one of those fits; each labelling is scored against the human labels
(Hungarian-matched frame accuracy, ARI) beside HACA given the true K. The paper's synthetic
setting (section 5.1, ``benchmarks/_aca_synth.py``: 4 classes, equality kernel, flat ACA,
min_len 10 and max_len 15 or widened to the expected noise) gets the same criteria on flat
ACA fits for K = 2..8.

Protocol (declared before any result): the TRAIN pair is ``02_walk_punch_sword_wash`` and
``hdm_bd_0``. A criterion's parameter is chosen there only (the best mean train accuracy;
ties: more K found = true, then the first in the grid); every other recording and the
synthetic setting are held out and scored once per candidate, with its chosen parameter.

Criteria (``piece`` = ``max_len_s / 2`` = 1 s at the defaults, as the library's silhouette):

* ``sil1``: the library's default, the best silhouette under the DTAK distance ``2 - 2
  DTAK`` on pieces of 1 s (every 0.5 s), a piece labelled by its most frequent label;
* ``sil2``: the same on pieces of 2 s (``max_len_s``);
* ``silpiece(f)``: the same on pieces of f x ``max_len_s`` (the piece length chosen on the
  train pair);
* ``silfine``: the same with HACA's fine segments (primitives) as the pieces;
* ``merge(tau)``: the largest K whose clusters are all distinct: for every pair, the mean
  between-cluster DTAK similarity of the 1 s pieces over the geometric mean of the two
  within-cluster similarities stays below tau;
* ``mindur(D)``: the best ``sil1`` among the K whose every cluster holds at least D x
  ``max_len_s`` (D = 1: 2 s at the defaults);
* ``eigengap``: the largest gap of the normalized 1 s piece DTAK kernel's eigenvalues;
* ``bic(lam)``: ``m log(J_K / m) + lam K log m`` with J_K the coarse ACA objective (eq. 5)
  and m the number of coarse units (fine segments; frames for flat ACA);
* ``margin(delta)``: the smallest K whose ``sil1`` is within delta of the best
  (``relmargin``: at least the fraction r of the best);
* ``silsigma(f)``: ``sil1`` under a frame kernel f x the default bandwidth;
* ``ch``: the Calinski-Harabasz index of the 1 s pieces in the DTAK kernel's feature space;
* ``consensus``: the K whose labelling agrees best (mean ARI) with those of the other K;
* ``stab(S)``: the K whose coarse labelling agrees best (mean pairwise ARI) over S coarse
  seeds, the smallest K within 0.02 of the best;
* ``mix((W, R))``: temporal mixing: ``sil1``'s labelling, then the pair of clusters that
  interleaves most (returns of one cluster within W seconds holding the other, at least R)
  merged while more than 2 clusters remain (``model_selection.merge_interleaved``); K found =
  the clusters left. W is in seconds, so on the synthetic setting (fps 1, segments of at
  least 10 frames) no gap of W <= 4 can hold a segment and ``mix`` equals ``sil1`` there.

Round p (declared before running, train ``02_walk_punch_sword_wash`` + ``hdm_dg_1`` via
``--train``; ``hdm_dg_1`` is a join sil1 gets right, so that under-selection costs on train),
criteria at another level than pairwise DTAK similarity:

* ``segpen(lam)``: a penalised kernel energy that counts segments, ``m log(E_K / m) + lam R_K
  log m``: E_K the kernel k-means energy of the 1 s pieces under HACA's labelling, R_K its runs;
* ``gap(rule)``: the gap statistic (Tibshirani et al. 2001) of k-means in the kernel PCA
  embedding of the 1 s piece kernel against 10 uniform references ("1se" or "max" rule);
* ``spread(r)``: ``sil1``'s labelling, then clusters merged while the union's spread (mean
  pairwise DTAK distance of its pieces) is at most r x the larger part's;
* ``resample(v)``: the K whose fits agree most (mean ARI) with HACA refitted on nearby window
  lengths ("len": min/max_len_s x 0.8, 1.25), on every other frame ("sub") or both.

None passed the rule declared in the issue note (train better, held-out mean not lower, no
recording lower by > 0.01, K = true more often, synthetic not lower): segpen(1) and
resample("len") fixed the train join (K 3, 0.897) but lost elsewhere (86_01 -0.110 / -0.227;
synthetic 0.573 / 0.841 against 0.863), gap under-selected, spread never merged at r <= 1 and
merged the train join down to K = 2 above. ``--split-diagnosis`` prints what the over-splits
are (bone-angle statistics per sil1 cluster, the DTAK ratio of split pairs against pairs of
different actions) and the accuracy of every K.

Run: ``nice -n 5 .venv/bin/python benchmarks/k_selection.py [--only sil1,merge] [--synthetic 10]
[--train A,B] [--split-diagnosis | --diagnosis-only] [--mixing-diagnosis]``
(every criterion: about 2 minutes on the shared 2-core machine; ``stab`` refits twice more)
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from _aca_synth import synthetic_sequence  # noqa: E402

from streamseg.config import ACAConfig  # noqa: E402
from streamseg.evaluation.metrics import matched_frame_accuracy  # noqa: E402
from streamseg.offline.dtak import frame_kernel, segment_dtak  # noqa: E402
from streamseg.offline.model_selection import (  # noqa: E402
    SILHOUETTE_FRAMES,
    fit_aca,
    merge_interleaved,
    model_from_config,
)

#: declared before any result was seen: parameters are chosen on these two only
TRAIN = ("02_walk_punch_sword_wash", "hdm_bd_0")


def ari(a, b) -> float:
    from sklearn.metrics import adjusted_rand_score

    return float(adjusted_rand_score(a, b))


def fit_every_k(config, X, fps, ks) -> dict:
    """K -> the configured model fitted to ``X`` (HACA: one fine level for every K)."""
    if config.hierarchical:
        return dict(model_from_config(config, fps).fit_each(X, ks))
    return {k: model_from_config(replace(config, n_clusters=k), fps).fit(X) for k in ks}


class Case:
    """One sequence: its fits for every K and the DTAK matrices the criteria need."""

    def __init__(self, name, X, truth, fps, config, ks):
        self.name, self.X, self.truth, self.fps, self.config = name, X, truth, fps, config
        self.k_true = int(np.unique(truth[truth >= 0]).size)
        t0 = time.perf_counter()
        self.fits = fit_every_k(config, X, fps, ks)
        self.fit_s = time.perf_counter() - t0
        if self.k_true not in self.fits:
            self.true_fit = model_from_config(replace(config, n_clusters=self.k_true), fps).fit(X)
        else:
            self.true_fit = self.fits[self.k_true]
        n = X.shape[0]
        self.stride = max(1, -(-n // SILHOUETTE_FRAMES))
        self.Kf = frame_kernel(X[::self.stride], kernel=config.kernel, sigma=config.sigma)
        self._pieces = {}

    def labels(self, k):
        return np.asarray(self.fits[k].labels_)

    def dtak(self, bounds, Kf=None):
        """(m, m) DTAK between frame ranges [(s, e)] on the strided frame kernel ``Kf``
        (default: the configured one)."""
        Kf = self.Kf if Kf is None else Kf
        m = Kf.shape[0]
        b = []
        for s, e in bounds:
            a = min(s // self.stride, m - 1)
            b.append((a, max(a + 1, min(e // self.stride, m))))
        return segment_dtak(Kf, b)

    def pieces(self, seconds_or_frames, frames=False):
        """(starts, length, S) for equal pieces every length // 2."""
        key = (seconds_or_frames, frames)
        if key not in self._pieces:
            n = self.X.shape[0]
            p = int(seconds_or_frames) if frames else int(round(seconds_or_frames * self.fps))
            p = max(2, min(p, n))
            starts = np.arange(0, n - p + 1, max(1, p // 2))
            S = self.dtak([(s, s + p) for s in starts])
            self._pieces[key] = (starts, p, S)
        return self._pieces[key]

    def score(self, labels):
        keep = self.truth >= 0
        return (matched_frame_accuracy(labels[keep], self.truth[keep])[0],
                ari(self.truth[keep], labels[keep]))


def _piece_labels(labels, starts, p):
    return np.array([np.bincount(labels[s:s + p]).argmax() for s in starts])


def silhouette(D, lab) -> float:
    """Mean silhouette of labels ``lab`` under distances ``D`` (-1 with one label)."""
    ids, inv = np.unique(lab, return_inverse=True)
    if ids.size < 2:
        return -1.0
    H = np.eye(ids.size)[inv]  # (m, c) one-hot
    cnt = H.sum(0)
    sums = D @ H
    own_n = cnt[inv] - 1
    a = np.where(own_n > 0, sums[np.arange(lab.size), inv] / np.maximum(own_n, 1), 0.0)
    mean = sums / cnt
    mean[np.arange(lab.size), inv] = np.inf
    b = mean.min(1)
    sil = np.where(own_n > 0, (b - a) / np.maximum(np.maximum(a, b), 1e-12), 0.0)
    return float(sil.mean())


def _sil_pieces(case, k, piece_s):
    starts, p, S = case.pieces(case.config.max_len_s * piece_s, frames=False)
    D = np.clip(2.0 - 2.0 * S, 0.0, None)
    return silhouette(D, _piece_labels(case.labels(k), starts, p))


def _argbest(scores: dict, higher=True):
    ks = sorted(scores)
    vals = [scores[k] for k in ks]
    i = int(np.argmax(vals) if higher else np.argmin(vals))  # the first (smallest K) of ties
    return ks[i]


def crit_sil(case, piece):  # piece in units of max_len_s: 0.5 = 1 s at the defaults
    return _argbest({k: _sil_pieces(case, k, piece) for k in case.fits})


def crit_silfine(case, _=None):
    if not case.config.hierarchical:
        return None
    any_fit = next(iter(case.fits.values()))
    bounds = [(s, e) for s, e, _ in any_fit.fine_segments_]
    key = ("fine", 0)
    if key not in case._pieces:
        case._pieces[key] = case.dtak(bounds)
    D = np.clip(2.0 - 2.0 * case._pieces[key], 0.0, None)
    scores = {}
    for k in case.fits:
        lab = case.labels(k)
        scores[k] = silhouette(D, np.array([np.bincount(lab[s:e]).argmax() for s, e in bounds]))
    return _argbest(scores)


def _cluster_sim(case, k):
    starts, p, S = case.pieces(case.config.max_len_s * 0.5)
    lab = _piece_labels(case.labels(k), starts, p)
    ids, inv = np.unique(lab, return_inverse=True)
    H = np.eye(ids.size)[inv]
    cnt = H.sum(0)
    W = H.T @ S @ H
    # within: without the piece itself (its DTAK with itself is 1)
    within = (np.diag(W) - cnt) / np.maximum(cnt * (cnt - 1), 1)
    between = W / np.outer(cnt, cnt)
    return within, between, cnt


def crit_merge(case, tau):
    best = min(case.fits)
    for k in sorted(case.fits):
        within, between, cnt = _cluster_sim(case, k)
        c = within.size
        w = np.sqrt(np.outer(np.maximum(within, 1e-12), np.maximum(within, 1e-12)))
        ratio = between / w
        ratio[np.arange(c), np.arange(c)] = 0.0
        if c == k and ratio.max() < tau:
            best = k
    return best


def crit_mindur(case, times_max_len):
    ok = {}
    for k in case.fits:
        cnt = np.bincount(case.labels(k), minlength=k)
        if cnt.size >= k and cnt[:k].min() >= times_max_len * case.config.max_len_s * case.fps:
            ok[k] = _sil_pieces(case, k, 0.5)
    return _argbest(ok) if ok else min(case.fits)


def crit_eigengap(case, _=None):
    _, _, S = case.pieces(case.config.max_len_s * 0.5)
    S = (S + S.T) / 2
    d = S.sum(1)
    L = S / np.sqrt(np.outer(d, d))
    ev = np.sort(np.linalg.eigvalsh(L))[::-1]
    ks = sorted(case.fits)
    gaps = {k: ev[k - 1] - ev[k] for k in ks if k < ev.size}
    return _argbest(gaps) if gaps else min(ks)


def crit_bic(case, lam):
    scores = {}
    for k, f in case.fits.items():
        m = len(f.fine_segments_) if case.config.hierarchical else case.X.shape[0]
        J = max(float(f.objective_), 1e-12)
        scores[k] = m * np.log(J / m) + lam * k * np.log(m)
    return _argbest(scores, higher=False)


def crit_stab(case, n_seeds):
    """Agreement of the coarse labellings over seeds (the fine level kept)."""
    key = ("stab", n_seeds)
    if key not in case._pieces:
        runs = {k: [case.labels(k)] for k in case.fits}
        for seed in range(1, n_seeds):
            cfg = replace(case.config, random_state=(case.config.random_state or 0) + 1000 * seed)
            fits = fit_every_k(cfg, case.X, case.fps, sorted(case.fits))
            for k in case.fits:
                runs[k].append(np.asarray(fits[k].labels_))
        case._pieces[key] = {k: np.mean([ari(a, b) for i, a in enumerate(r) for b in r[i + 1:]])
                             for k, r in runs.items()}
    agree = case._pieces[key]
    top = max(agree.values())
    return min(k for k, v in agree.items() if v >= top - 0.02)


def crit_margin(case, delta):
    """The smallest K whose 1 s piece silhouette is within ``delta`` of the best; a delta
    below 1 is absolute, written as "r0.9" it is relative (at least 0.9 x the best)."""
    scores = {k: _sil_pieces(case, k, 0.5) for k in case.fits}
    top = max(scores.values())
    if isinstance(delta, str):
        floor = float(delta[1:]) * top
    else:
        floor = top - delta
    return min(k for k, v in scores.items() if v >= floor)


def crit_silsigma(case, factor):
    """``sil1`` under a frame kernel ``factor`` x wider than the default bandwidth."""
    from streamseg.offline.dtak import default_sigma

    key = ("sigma", factor)
    if key not in case._pieces:
        n = case.X.shape[0]
        Xs = case.X[::case.stride]
        Kf = frame_kernel(Xs, kernel=case.config.kernel,
                          sigma=factor * default_sigma(Xs) if case.config.kernel == "gaussian"
                          else None)
        p = max(2, min(int(round(case.config.max_len_s * 0.5 * case.fps)), n))
        starts = np.arange(0, n - p + 1, max(1, p // 2))
        S = case.dtak([(s, s + p) for s in starts], Kf)
        case._pieces[key] = (starts, p, np.clip(2.0 - 2.0 * S, 0.0, None))
    starts, p, D = case._pieces[key]
    return _argbest({k: silhouette(D, _piece_labels(case.labels(k), starts, p))
                     for k in case.fits})


def crit_ch(case, _=None):
    """Calinski-Harabasz in the feature space of the 1 s piece DTAK kernel."""
    starts, p, S = case.pieces(case.config.max_len_s * 0.5)
    n = S.shape[0]
    total = n - S.sum() / n
    scores = {}
    for k in case.fits:
        lab = _piece_labels(case.labels(k), starts, p)
        ids = np.unique(lab)
        if ids.size < 2 or ids.size >= n:
            continue
        within = sum((lab == c).sum() - S[np.ix_(lab == c, lab == c)].sum() / (lab == c).sum()
                     for c in ids)
        c = ids.size
        scores[k] = ((total - within) / (c - 1)) / max(within / (n - c), 1e-12)
    return _argbest(scores) if scores else min(case.fits)


def crit_mix(case, param):
    """Temporal mixing: ``sil1``'s labelling with the clusters that interleave merged.

    ``param`` = (W seconds, R returns): :func:`merge_interleaved` merges the pair of clusters
    with the most returns (two runs of one cluster at most W apart, the other in the gap)
    while it has at least R and more than 2 clusters remain. Returns (K found, labels)."""
    window_s, min_returns = param
    k = crit_sil(case, 0.5)
    lab = merge_interleaved(case.labels(k), int(round(window_s * case.fps)), min_returns)
    return int(lab.max()) + 1, lab


def crit_consensus(case, _=None):
    """The K whose labelling agrees best (mean ARI) with the labellings of every other K."""
    ks = sorted(case.fits)
    agree = {k: np.mean([ari(case.labels(k), case.labels(j)) for j in ks if j != k])
             for k in ks}
    return _argbest(agree)


# --- round p: criteria at another level than pairwise DTAK similarity (declared before running)

def _piece_energy(S, lab):
    """Kernel k-means energy of piece labels ``lab`` in the feature space of kernel ``S``:
    sum over clusters of n_c - sum(S_cc) / n_c (the within-cluster scatter)."""
    e = 0.0
    for c in np.unique(lab):
        idx = lab == c
        e += idx.sum() - S[np.ix_(idx, idx)].sum() / idx.sum()
    return max(float(e), 1e-12)


def _n_runs(labels) -> int:
    return int(1 + np.count_nonzero(labels[1:] != labels[:-1])) if labels.size else 0


def crit_segpen(case, lam):
    """Penalised kernel energy counting segments: m log(E_K / m) + lam R_K log m (minimised),
    E_K the 1 s pieces' kernel k-means energy under HACA's labelling, R_K its runs."""
    starts, p, S = case.pieces(case.config.max_len_s * 0.5)
    S = (S + S.T) / 2
    m = S.shape[0]
    scores = {}
    for k in case.fits:
        lab = case.labels(k)
        e = _piece_energy(S, _piece_labels(lab, starts, p))
        scores[k] = m * np.log(e / m) + lam * _n_runs(lab) * np.log(m)
    return _argbest(scores, higher=False)


def _kernel_embedding(S, var=0.95, max_dim=20):
    """(m, r) kernel PCA coordinates of the centred kernel ``S``: the leading components up to
    ``var`` of the variance, at most ``max_dim``."""
    S = (S + S.T) / 2
    m = S.shape[0]
    H = np.eye(m) - 1.0 / m
    ev, V = np.linalg.eigh(H @ S @ H)
    ev, V = ev[::-1], V[:, ::-1]
    pos = ev > 1e-10 * max(ev[0], 1e-300)
    ev, V = ev[pos], V[:, pos]
    r = int(min(max_dim, np.searchsorted(np.cumsum(ev) / ev.sum(), var) + 1, ev.size))
    return V[:, :r] * np.sqrt(ev[:r])


def gap_statistic(Z, ks, n_ref=10, seed=0):
    """Gap(k) and s_k (Tibshirani, Walther, Hastie 2001) of k-means on the rows of ``Z`` against
    ``n_ref`` uniform references in its principal box (Z is already in principal axes)."""
    from sklearn.cluster import KMeans

    def logw(A, k):
        return np.log(max(KMeans(k, n_init=4, random_state=0).fit(A).inertia_, 1e-300))

    rng = np.random.default_rng(seed)
    lo, hi = Z.min(0), Z.max(0)
    refs = [rng.uniform(lo, hi, size=Z.shape) for _ in range(n_ref)]
    gap, sd = {}, {}
    for k in ks:
        ref = np.array([logw(R, k) for R in refs])
        gap[k] = float(ref.mean() - logw(Z, k))
        sd[k] = float(ref.std() * np.sqrt(1 + 1 / n_ref))
    return gap, sd


def crit_gap(case, rule):
    key = ("gap",)
    if key not in case._pieces:
        _, _, S = case.pieces(case.config.max_len_s * 0.5)
        Z = _kernel_embedding(S)
        ks = [k for k in sorted(case.fits) if k < Z.shape[0]]
        case._pieces[key] = gap_statistic(Z, ks) if ks else ({min(case.fits): 0.0}, {})
    gap, sd = case._pieces[key]
    ks = sorted(gap)
    if rule == "max":
        return _argbest(gap)
    for a, b in zip(ks[:-1], ks[1:]):
        if gap[a] >= gap[b] - sd[b]:
            return a
    return ks[-1]


def merge_by_spread(labels, starts, p, D, r, min_clusters=2):
    """Merge the pair of clusters whose union's spread (mean pairwise distance ``D`` among its
    pieces) over the larger part's spread is lowest, while it is <= ``r`` and more than
    ``min_clusters`` clusters remain. Returns per-frame labels 0..c'-1."""
    lab = np.unique(np.asarray(labels), return_inverse=True)[1]
    while lab.max() + 1 > min_clusters:
        pl = _piece_labels(lab, starts, p)
        ids = np.unique(pl)

        def spread(idx):
            n = idx.sum()
            return D[np.ix_(idx, idx)].sum() / (n * (n - 1)) if n > 1 else 0.0

        sp = {c: spread(pl == c) for c in ids}
        best = None
        for i, a in enumerate(ids):
            for b in ids[i + 1:]:
                ratio = spread((pl == a) | (pl == b)) / max(sp[a], sp[b], 1e-12)
                if best is None or ratio < best[0]:
                    best = (ratio, a, b)
        if best is None or best[0] > r:
            break
        lab = np.unique(np.where(lab == best[2], best[1], lab), return_inverse=True)[1]
    return lab


def crit_spread(case, r):
    k = crit_sil(case, 0.5)
    starts, p, S = case.pieces(case.config.max_len_s * 0.5)
    D = np.clip(2.0 - 2.0 * (S + S.T) / 2, 0.0, None)
    lab = merge_by_spread(case.labels(k), starts, p, D, r)
    return int(lab.max()) + 1, lab


def _variant_fits(case, variant):
    """Per-frame labels of HACA refitted on a resampled window, K -> [labels, ...]."""
    key = ("resample", variant)
    if key in case._pieces:
        return case._pieces[key]
    cfg, n, ks = case.config, case.X.shape[0], sorted(case.fits)
    runs = {k: [] for k in ks}

    if variant == "both":
        for v in ("len", "sub"):
            for k, labs in _variant_fits(case, v).items():
                runs[k] += labs
    elif variant == "len":
        for f in (0.8, 1.25):
            c = replace(cfg, min_len_s=cfg.min_len_s * f, max_len_s=cfg.max_len_s * f)
            for k, m in fit_every_k(c, case.X, case.fps, ks).items():
                runs[k].append(np.asarray(m.labels_))
    else:  # "sub": every other frame, both phases, at half the frame rate
        for o in (0, 1):
            fits = fit_every_k(cfg, case.X[o::2], case.fps / 2, ks)
            idx = np.clip(np.round((np.arange(n) - o) / 2).astype(int), 0, (n - o - 1) // 2)
            for k, m in fits.items():
                runs[k].append(np.asarray(m.labels_)[idx])
    case._pieces[key] = runs
    return runs


def crit_resample(case, variant):
    runs = _variant_fits(case, variant)
    agree = {k: np.mean([ari(case.labels(k), v) for v in runs[k]]) for k in case.fits}
    top = max(agree.values())
    return min(k for k, v in agree.items() if v >= top - 0.02)


#: name -> (function, parameter grid); None: no parameter
CRITERIA = {
    "sil1": (crit_sil, [0.5]),
    "sil2": (crit_sil, [1.0]),
    "silpiece": (crit_sil, [0.25, 0.5, 1.0, 1.5, 2.0, 3.0]),
    "silfine": (crit_silfine, [None]),
    "merge": (crit_merge, [0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.95]),
    "mindur": (crit_mindur, [0.5, 1.0, 1.5, 2.0, 3.0]),
    "eigengap": (crit_eigengap, [None]),
    "bic": (crit_bic, [0.25, 0.5, 1.0, 2.0, 4.0, 8.0]),
    "stab": (crit_stab, [3]),
    "margin": (crit_margin, [0.01, 0.02, 0.03, 0.05]),
    "relmargin": (crit_margin, ["r0.95", "r0.9", "r0.85", "r0.8"]),
    "consensus": (crit_consensus, [None]),
    "silsigma": (crit_silsigma, [0.5, 2.0, 4.0, 8.0]),
    "ch": (crit_ch, [None]),
    # declared before any run: W ascending, R descending (the most conservative first)
    "mix": (crit_mix, [(w, r) for w in (1, 2, 3, 4) for r in (4, 3, 2)]),
    # round p, declared before any run (train 02_walk_punch_sword_wash + hdm_dg_1)
    "segpen": (crit_segpen, [0.25, 0.5, 1.0, 2.0, 4.0, 8.0]),
    "gap": (crit_gap, ["1se", "max"]),
    "spread": (crit_spread, [0.9, 1.0, 1.1, 1.2, 1.3]),
    "resample": (crit_resample, ["len", "sub", "both"]),
}


def mocap_cases(config, ks):
    from live_relabel import recordings

    from streamseg.skeleton import bone_angles

    cases = {}
    for name, (rec, truth) in recordings().items():
        feats = bone_angles(rec.positions, rec.skeleton, inclinations=True)
        feats = feats.astype(np.float32).astype(np.float64)  # the daemon keeps float32
        cases[name] = Case(name, feats, truth, rec.fps, config, ks)
        cases[name].library_k = fit_aca(feats, config, rec.fps).n_clusters_  # cross-check
        print(f"  fitted {name}: {feats.shape[0]} frames, K 2..{max(ks)} in "
              f"{cases[name].fit_s:.1f} s", file=sys.stderr, flush=True)
    return cases


def synthetic_cases(n_seq, ks):
    """The settings of ``benchmarks/aca_synthetic.py`` (same seeds)."""
    out = {}
    for p in (0.0, 0.1, 0.2, 0.3):
        for max_len in sorted({15, round(15 * (1 + p))}):
            cases = []
            for i in range(n_seq):
                rng = np.random.default_rng(1000 * int(p * 10) + i)
                x, truth = synthetic_sequence(20, p, rng)
                cfg = ACAConfig(kernel="equality", hierarchical=False, min_len_s=10,
                                max_len_s=max_len, n_init=10, random_state=i, k_reduce=None)
                cases.append(Case(f"syn_{p}_{max_len}_{i}", x[:, None], truth, 1.0, cfg, ks))
            out[(p, max_len)] = cases
    return out


def _majority(truth) -> str:
    t = truth[truth >= 0]
    return str(np.bincount(t).argmax()) if t.size else "-"


def mixing_diagnosis(cases, window_s=4.0):
    """Why ``mix`` merges or not: for every recording, the pairs of ``sil1`` clusters whose
    frames are mostly one human action (an over-split) against the other pairs, with their
    returns within ``window_s`` (:func:`streamseg.offline.model_selection.mixing_counts`) and
    whether they share a boundary (a run of one right after a run of the other)."""
    from streamseg.offline.model_selection import mixing_counts

    print(f"\n## Temporal mixing diagnosis (sil1's labelling, returns within {window_s:g} s)\n")
    print("| recording | K found / true | over-split pairs: returns, adjacent | other pairs with "
          "returns >= 1 | sil1 runs, cluster:seconds[human action] |")
    print("|---|---|---|---|---|")
    for name, c in cases.items():
        lab = c.labels(crit_sil(c, 0.5))
        lab = np.unique(lab, return_inverse=True)[1]
        keep = c.truth >= 0
        major = [np.bincount(c.truth[keep & (lab == j)]).argmax() if (keep & (lab == j)).any()
                 else -1 for j in range(lab.max() + 1)]
        N = mixing_counts(lab, int(round(window_s * c.fps)))
        st = np.flatnonzero(np.r_[True, lab[1:] != lab[:-1]])
        en = np.r_[st[1:], lab.size]
        adj = {frozenset((int(lab[a]), int(lab[b]))) for a, b in zip(st[:-1], st[1:])}
        same, other = [], []
        for a in range(N.shape[0]):
            for b in range(a + 1, N.shape[0]):
                tag = f"{a}-{b}: {N[a, b]}, {'adj' if frozenset((a, b)) in adj else 'apart'}"
                if major[a] == major[b]:
                    same.append(tag)
                elif N[a, b]:
                    other.append(f"{a}-{b}: {N[a, b]}")
        runs = " ".join(f"{lab[s]}:{(e - s) / c.fps:.1f}[{_majority(c.truth[s:e])}]"
                        for s, e in zip(st, en))
        print(f"| {name} | {lab.max() + 1} / {c.k_true} | {'; '.join(same) or '-'} | "
              f"{'; '.join(other) or '-'} | {runs} |")


def _action_names(name, k_true):
    """Human action names of a recording's label ids (CMU 02 joins: the trials; HDM05 joins:
    the plan's classes)."""
    if name.startswith("02_"):
        return name.split("_")[1:]
    if name.startswith("hdm_"):
        from live_relabel import DATA

        from streamseg.evaluation.datasets import hdm05_action_plans

        return [c for c, _ in hdm05_action_plans(DATA)[name][1]]
    return [str(i) for i in range(k_true)]


def split_diagnosis(cases, top=3):
    """What HACA's over-splits are: for every recording where ``sil1`` finds more clusters
    than human actions, sil1's runs (0-based frames, end exclusive) with their human action;
    per cluster the bone angles that move most (standard deviation, degrees) and, for each
    pair of clusters whose frames are mostly one human action, the angles whose means differ
    most (difference in degrees, and in pooled standard deviations) and the pieces' DTAK
    between/within ratio (``merge``'s quantity)."""
    from streamseg.skeleton.bones import FEATURE_NAMES

    print("\n## Split diagnosis (sil1's labelling; angles in degrees)\n")
    for name, c in cases.items():
        k = crit_sil(c, 0.5)
        if k <= c.k_true:
            continue
        lab = np.unique(c.labels(k), return_inverse=True)[1]
        acts = _action_names(name, c.k_true)
        keep = c.truth >= 0
        major = [int(np.bincount(c.truth[keep & (lab == j)]).argmax()) for j in range(k)]
        st = np.flatnonzero(np.r_[True, lab[1:] != lab[:-1]])
        en = np.r_[st[1:], lab.size]

        def act(s, e, truth=c.truth, acts=acts):
            t = truth[s:e]
            return acts[np.bincount(t[t >= 0]).argmax()] if (t >= 0).any() else "-"

        print(f"### {name}: K found {k}, true {c.k_true}\n")
        print("runs: " + ", ".join(f"c{lab[s]} [{s}, {e}) {(e - s) / c.fps:.1f} s {act(s, e)}"
                                   for s, e in zip(st, en)) + "\n")
        deg = np.degrees(c.X)
        print("| cluster | human action (share) | seconds | moves most: angle sd |")
        print("|---|---|---|---|")
        for j in range(k):
            f = lab == j
            share = np.mean(c.truth[f] == major[j])
            sd = deg[f].std(0)
            mv = ", ".join(f"{FEATURE_NAMES[i]} {sd[i]:.0f}" for i in np.argsort(sd)[::-1][:top])
            print(f"| c{j} | {acts[major[j]]} ({share:.2f}) | {f.sum() / c.fps:.1f} | {mv} |")
        within, between, _ = _cluster_sim(c, k)
        pairs = [(a, b) for a in range(k) for b in range(a + 1, k) if major[a] == major[b]]
        if pairs:
            print("\n| split pair | action | mean differs most: a vs b (diff / pooled sd) "
                  "| DTAK between / sqrt(within a x within b) |")
            print("|---|---|---|---|")
        for a, b in pairs:
            fa, fb = lab == a, lab == b
            ma, mb = deg[fa].mean(0), deg[fb].mean(0)
            pooled = np.sqrt((deg[fa].var(0) + deg[fb].var(0)) / 2) + 1e-9
            z = np.abs(ma - mb) / pooled
            diff = ", ".join(f"{FEATURE_NAMES[i]} {ma[i]:.0f} vs {mb[i]:.0f} ({z[i]:.1f})"
                             for i in np.argsort(z)[::-1][:top])
            ratio = (between[a, b] / np.sqrt(max(within[a], 1e-12) * max(within[b], 1e-12))
                     if max(a, b) < within.size else float("nan"))
            print(f"| c{a}-c{b} | {acts[major[a]]} | {diff} | {ratio:.2f} |")
        other = [between[a, b] / np.sqrt(max(within[a], 1e-12) * max(within[b], 1e-12))
                 for a in range(within.size) for b in range(a + 1, within.size)
                 if major[a] != major[b]]
        if other:
            print(f"\npairs of clusters of two different actions: DTAK ratio min "
                  f"{min(other):.2f}, median {np.median(other):.2f}, max {max(other):.2f}")
        print()


def k_profile(cases):
    """Descriptive, not a criterion: accuracy of HACA's fit at every K, the K that would be
    best (read off the labels) beside K true and sil1's K."""
    ks = sorted(next(iter(cases.values())).fits)
    print("\n## Accuracy at every K (descriptive: the best K is read off the human labels)\n")
    print("| recording | K true | sil1 K | best K | " + " | ".join(f"K={k}" for k in ks) + " |")
    print("|---|---|---|---|" + "---|" * len(ks))
    for name, c in cases.items():
        acc = {k: c.score(c.labels(k))[0] for k in ks}
        print(f"| {name} | {c.k_true} | {crit_sil(c, 0.5)} | {_argbest(acc)} | "
              + " | ".join(f"{acc[k]:.3f}" for k in ks) + " |")


def pick(case, name, param):
    fn, _ = CRITERIA[name]
    k = fn(case, param)
    if k is None:
        return None
    k, labels = k if isinstance(k, tuple) else (k, case.labels(k))
    acc, a = case.score(labels)
    return k, acc, a


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="", help="comma-separated criteria (default: all)")
    ap.add_argument("--synthetic", type=int, default=10, help="sequences per setting (0: skip)")
    ap.add_argument("--train", default=",".join(TRAIN),
                    help="comma-separated train pair (default: the first rounds' pair; round p "
                    "declared 02_walk_punch_sword_wash,hdm_dg_1)")
    ap.add_argument("--split-diagnosis", action="store_true",
                    help="print sil1's clusters of each over-split recording: frame ranges, "
                    "the human action, which bone angles move and which tell split halves apart")
    ap.add_argument("--diagnosis-only", action="store_true",
                    help="the split diagnosis without the criteria tables")
    ap.add_argument("--mixing-diagnosis", action="store_true",
                    help="print why temporal mixing merges or not (sil1's runs per recording)")
    args = ap.parse_args()
    names = [c for c in CRITERIA if not args.only or c in args.only.split(",")]
    train_names = tuple(args.train.split(","))
    config = ACAConfig()
    ks = list(range(2, config.k_max + 1))
    print(f"ACA: {config}\nK tried: {ks}; train pair (declared before any result): "
          f"{', '.join(train_names)}\n")
    cases = mocap_cases(config, ks)
    if args.split_diagnosis or args.diagnosis_only:
        split_diagnosis(cases)
        k_profile(cases)
        if args.diagnosis_only:
            return
    train = [cases[n] for n in train_names]
    held = [c for n, c in cases.items() if n not in train_names]
    true_scores = {n: c.score(np.asarray(c.true_fit.labels_)) for n, c in cases.items()}

    chosen = {}
    print("## Train pair: every parameter\n")
    print("| criterion | param | " + " | ".join(f"{n} K / acc" for n in train_names)
          + " | mean acc |")
    print("|---|---|" + "---|" * len(train_names) + "---|")
    for name in names:
        best = None
        for param in CRITERIA[name][1]:
            res = [pick(c, name, param) for c in train]
            if any(r is None for r in res):
                continue
            mean = float(np.mean([r[1] for r in res]))
            hits = sum(r[0] == c.k_true for r, c in zip(res, train))
            print(f"| {name} | {param} | " + " | ".join(f"{r[0]} / {r[1]:.3f}" for r in res)
                  + f" | {mean:.3f} |", flush=True)
            if best is None or (mean, hits) > best[0]:
                best = ((mean, hits), param)
        chosen[name] = best[1]
    print("\n| HACA K true | - | " + " | ".join(
        f"{c.k_true} / {true_scores[c.name][0]:.3f}" for c in train) + " | "
        f"{np.mean([true_scores[c.name][0] for c in train]):.3f} |")

    print("\n## Every recording, each criterion with its chosen parameter "
          "(K found / true, acc, ARI; HACA with K true last)\n")
    print("| recording | K true | " + " | ".join(f"{n}({chosen[n]})" for n in names)
          + " | HACA K true acc / ari |")
    print("|---|---|" + "---|" * len(names) + "---|")
    table = {n: {} for n in names}
    for cname, c in cases.items():
        cells = []
        for name in names:
            r = pick(c, name, chosen[name])
            table[name][cname] = r
            cells.append(f"{r[0]}: {r[1]:.3f} / {r[2]:.2f}")
        tag = " (train)" if cname in train_names else ""
        print(f"| {cname}{tag} | {c.k_true} | " + " | ".join(cells) + f" | "
              f"{true_scores[cname][0]:.3f} / {true_scores[cname][1]:.2f} |", flush=True)

    if "sil1" in names:
        same = sum(table["sil1"][n][0] == c.library_k for n, c in cases.items())
        print(f"\nsil1 picks the K of the library's fit_aca on {same}/{len(cases)} recordings")
    print(f"\n## Summary over the {len(held)} held-out recordings\n")
    print("| criterion | param | mean acc | mean ari | K found = true | K over / under "
          "| within 0.03 of K true | worst gap to K true | mean acc, all 14 |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in names:
        r = [table[name][c.name] for c in held]
        gaps = [true_scores[c.name][0] - x[1] for c, x in zip(held, r)]
        allm = np.mean([table[name][n][1] for n in cases])
        print(f"| {name} | {chosen[name]} | {np.mean([x[1] for x in r]):.3f} | "
              f"{np.mean([x[2] for x in r]):.3f} | "
              f"{sum(x[0] == c.k_true for c, x in zip(held, r))}/{len(held)} | "
              f"{sum(x[0] > c.k_true for c, x in zip(held, r))} / "
              f"{sum(x[0] < c.k_true for c, x in zip(held, r))} | "
              f"{sum(g <= 0.03 for g in gaps)}/{len(held)} | {max(gaps):.3f} | {allm:.3f} |")
    print(f"| HACA K true | - | {np.mean([true_scores[c.name][0] for c in held]):.3f} | "
          f"{np.mean([true_scores[c.name][1] for c in held]):.3f} | - | - | - | - | "
          f"{np.mean([v[0] for v in true_scores.values()]):.3f} |")

    if args.mixing_diagnosis:
        mixing_diagnosis(cases)

    if args.synthetic:
        print(f"\n## Synthetic (section 5.1, flat ACA, equality kernel, {args.synthetic} "
              "sequences per setting; held out): mean acc, K = 4 found on how many\n")
        syn = synthetic_cases(args.synthetic, ks)
        print("| p_noise | max_len | K = 4 acc | " + " | ".join(
            f"{n}({chosen[n]})" for n in names) + " |")
        print("|---|---|---|" + "---|" * len(names))
        tot = {n: [] for n in names}
        for (p, max_len), cs in syn.items():
            cells = []
            for name in names:
                r = [pick(c, name, chosen[name]) for c in cs]
                if any(x is None for x in r):
                    cells.append("-")
                    continue
                tot[name] += r
                cells.append(f"{np.mean([x[1] for x in r]):.3f} "
                             f"({sum(x[0] == 4 for x in r)}/{len(r)})")
            true = np.mean([c.score(np.asarray(c.true_fit.labels_))[0] for c in cs])
            print(f"| {p:.1f} | {max_len} | {true:.3f} | " + " | ".join(cells) + " |",
                  flush=True)
        print("| all | | | " + " | ".join(
            f"{np.mean([x[1] for x in tot[n]]):.3f} ({sum(x[0] == 4 for x in tot[n])}/"
            f"{len(tot[n])})" if tot[n] else "-" for n in names) + " |")


if __name__ == "__main__":
    main()
