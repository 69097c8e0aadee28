"""Replay of the streaming LOF decision in Python, for trying decision rules (lof_variants part 6).

The library's streaming detector maintains the LOF buffer; its values do not depend on the
decision parameters, so :func:`snapshots` records the buffer (LOF values and window centres)
after every window insertion. :func:`decide` then re-makes the library's causal decision window
by window from those snapshots, calling the same numba pieces (``robust_threshold``,
``dominates``, ``is_peak``, ``refine_cut``, ``contrast_at``), and optional extra rules:

- ``recent_s``: the threshold is the robust z-score of the LOF over the last ``recent_s``
  seconds of windows only (the stream's recent level), not the whole 75 s buffer;
- ``confirm``: a second scale (another window length's snapshots) must support the cut: some
  window of it centred within ``confirm_r`` frames of the cut, complete when the cut is
  decided, has LOF at least its own robust threshold (``confirm_mads``);
- ``contrast2``: the confirming contrast again at a second length (``contrast2`` frames each
  side, the before side since the previous cut, the after side clipped to the frames seen),
  which must reach ``min_contrast2``: a change must hold at two time scales;
- ``novelty``: the histogram of the whole current segment (previous cut .. cut frame) and the
  after side (``contrast`` frames, clipped to the frames seen) differ by at least ``novelty``
  (cosine distance), and the current segment has lasted at least ``min_seg`` frames (adopted
  in round 4, ``lof_variants.py --part 7``: ``LOFConfig.novelty``, default from the config).

Frame ring: the replay holds the whole recording's frame bins; every read is clipped to the
frames the streaming detector still holds (its ``history``), so with no extra rule the replay
gives the library's cuts exactly (checked in part 6 before any variant is scored).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from streamseg._kernels.histogram import contrast_at, refine_cut, span_contrast
from streamseg._kernels.peaks import dominates, is_peak, robust_threshold
from streamseg.config import LOFConfig
from streamseg.offline.lof import frame_bins
from streamseg.online.lof import StreamingLOFSegmenter
from streamseg.online.speed_features import lof_columns


@dataclass
class Snapshots:
    seq: np.ndarray      # (m,) sequence number of the newest window at each snapshot
    seen: np.ndarray     # (m,) frames seen at each snapshot
    lof: list            # m arrays: buffered LOF values, oldest first
    centres: list        # m arrays: buffered window centres, oldest first
    n_frames: int


def snapshots(angles, config: LOFConfig, fps: float) -> Snapshots:
    """The streaming detector's LOF buffer after each inserted window of ``angles`` (n, d)."""
    det = StreamingLOFSegmenter(config, fps, n_features=angles.shape[1])
    g = det.geometry
    seq, seen, lofs, cents = [], [], [], []
    bounds = [g["window"]] + list(range(g["window"] + g["step"], len(angles) + 1, g["step"]))
    start = 0
    for end in bounds:
        if end > len(angles):
            break
        before = det.n_windows_
        det.learn_many(angles[start:end])
        start = end
        if det.n_windows_ > before:
            seq.append(det.n_windows_ - 1)
            seen.append(det.n_frames_)
            lofs.append(det.buffer_lof())
            cents.append(det.buffer_centres())
    return Snapshots(np.array(seq, dtype=np.int64), np.array(seen, dtype=np.int64), lofs, cents,
                     len(angles))


#: with ``thr_exclude``, the fewest LOF values the threshold may read (else: all of them)
THR_MIN_WINDOWS = 10


def decide(angles, config: LOFConfig, fps: float, snaps: Snapshots, recent_s=None,
           mads=None, confirm: Snapshots | None = None, confirm_r=0, confirm_mads=1.0,
           novelty=None, min_seg=0, contrast2=0, min_contrast2=0.0,
           adaptive_k=None, fb=None, trace=None, recur=0.0, seg_contrast=0.0,
           min_energy=None, thr_exclude=0, recur_lookback=0):
    """Cut frames and latencies (frames) of the streaming decision replayed on ``snaps``.

    ``recur_lookback`` (frames, 0: the current segment; issue 11, round 16): how far back the
    recurrence check (``recur``) looks for a window like the cut's after side, whatever cuts
    lie between.
    ``thr_exclude`` (windows, 0: off; issue 11, round 15): the threshold's median and MAD
    read the buffered LOF values without those within this many windows of an earlier cut's
    peak window (all of them when fewer than :data:`THR_MIN_WINDOWS` remain).
    ``mads`` overrides ``config.threshold_mads`` (for the recent-window z-score), ``novelty``
    ``config.novelty`` (the library's check since round 4; None: the config's).
    ``adaptive_k = (snaps_by_k, alpha, k_max)``: each decision reads the LOF curve of
    ``k = clip(round(alpha * median segment length so far / step), config.k, k_max)`` (the
    segments the stream's own cuts closed; ``config.k`` before the first cut).
    ``recur`` > 0: the recurrence check (round 7, ``benchmarks/lof_recur.py``): the cut is
    rejected when the histogram of the ``window`` frames after it is within cosine distance
    ``recur`` of a buffered window lying wholly in the current segment (previous cut .. cut).
    ``seg_contrast`` > 0: the segment contrast check (round 9, ``benchmarks/lof_confirm.py``):
    the cut is rejected when the current segment holds a pair of buffered windows wholly
    inside it, ``ceil(window / step)`` steps apart, and the localisation contrast at the cut
    (window before / window after, ``refine_cut``'s score) is below ``seg_contrast`` times
    the largest contrast of such a pair (the segment's own variability).
    ``min_energy``: the energy check (round 9, ``benchmarks/lof_confirm.py``): with ``B`` the
    confirming contrast's before side and ``A`` its after side, each split at its midpoint,
    the cut is rejected when ``d(B, A) - (d(B1, B2) + d(A1, A2)) / 2 < min_energy`` (``d`` the
    cosine distance of the count histograms; None: off).
    ``trace``: a list that receives one dict per decided window (``benchmarks/lof_misses.py``):
    ``w``, ``centre``, ``stage`` (where it stopped: "gap", "threshold", "peak", "after"
    (too few frames after the cut), "contrast", "novelty", or "cut"), ``lof``, ``thr``, and
    once reached ``frame`` (the localised cut), ``peak_centre`` (the peak window's centre),
    ``first`` (the earliest cut frame the gap allows), ``search`` (the first and last
    frame localisation searched), ``con``, ``nov``, ``seg0``
    (the current segment's first frame), ``seen``.
    """
    c = config
    g = c.frames(fps)
    delay, min_gap, step, window = g["delay"], g["min_gap"], g["step"], g["window"]
    history, n = g["history"], snaps.n_frames
    n_mads = c.threshold_mads if mads is None else mads
    novelty = c.novelty if novelty is None else novelty
    if fb is None:  # the columns the library histograms (the features and their speeds)
        fb = frame_bins(lof_columns(angles, c, fps), c.bins)
    bins_, valid = fb
    # the checks read the pose columns only (LOFConfig.check_columns: not the root speeds)
    bins_ = np.ascontiguousarray(bins_[:, :c.check_columns(angles.shape[1])])
    left = np.zeros(bins_.shape[1] * c.bins, dtype=np.int64)
    right = left.copy()
    keep = np.zeros(2 * delay + 1, dtype=np.uint8)
    stack = np.zeros(4 * (2 * delay + 1) + 4, dtype=np.int64)
    st = dict(last_decided=-1, last_seq=-(1 << 40), last_frame=-(1 << 40), cut_ws=[])
    cuts, lats = [], []
    cum = None
    if novelty > 0 or recur > 0 or seg_contrast > 0:
        onehot = np.zeros((n, bins_.shape[1] * c.bins), dtype=np.int64)
        cols = np.arange(bins_.shape[1]) * c.bins + bins_.astype(np.int64)
        onehot[np.arange(n)[:, None], cols] = valid[:, None]
        cum = np.vstack([np.zeros((1, onehot.shape[1]), dtype=np.int64), np.cumsum(onehot, 0)])
    recent = None if recent_s is None else max(3, int(round(recent_s * fps / step)))

    def k_now():
        if not cuts:
            return c.k
        durs = np.diff([0] + cuts)
        k = int(round(adaptive_k[1] * float(np.median(durs)) / step))
        return min(max(k, c.k), adaptive_k[2])

    def one(w, hi, i, seen, emitted):
        if w <= st["last_decided"]:
            return
        st["last_decided"] = w
        src = snaps if adaptive_k is None else adaptive_k[0][k_now()]
        curve = src.lof[i]
        size = curve.shape[0]
        oldest = snaps.seq[i] - size + 1
        rec = dict(w=w, centre=int(src.centres[i][w - oldest]) if w >= oldest else -1,
                   seen=seen, seg0=max(0, st["last_frame"]))
        if trace is not None:
            trace.append(rec)
        rec["stage"] = "gap"
        if w < oldest or w - st["last_seq"] < min_gap:
            return
        if recent is None:
            ref = curve
        else:
            ref = np.ascontiguousarray(curve[max(0, size - recent):])
        if thr_exclude > 0 and st["cut_ws"]:
            # the level without the windows around earlier cuts (their own peaks)
            seqs = np.arange(size - ref.shape[0], size) + oldest
            far = np.ones(ref.shape[0], dtype=bool)
            for cw in st["cut_ws"]:
                far &= np.abs(seqs - cw) > thr_exclude
            if far.sum() >= THR_MIN_WINDOWS:
                ref = np.ascontiguousarray(ref[far])
        thr = max(c.min_score, robust_threshold(ref, ref.shape[0], n_mads,
                                                np.empty(max(1, ref.shape[0]))))
        yw = curve[w - oldest]
        rec.update(stage="threshold", lof=float(yw), thr=float(thr))
        if yw < thr:
            return
        lo = max(oldest, w - delay)
        rec["stage"] = "peak"
        if not (dominates(curve, lo - oldest, hi - oldest, w - oldest, min_gap)
                and is_peak(curve, lo - oldest, hi - oldest, w - oldest, c.dp_tolerance, keep,
                            stack)):
            return
        cf = int(src.centres[i][w - oldest])
        ring_old = max(0, seen - history)
        first = st["last_frame"] + min_gap * step
        # the frames refine_cut searches (lo > hi: none, the centre stays)
        rec.update(peak_centre=cf, first=first,
                   search=(max(cf - g["refine"], ring_old + window, first),
                           min(cf + g["refine"], seen - window)))
        if g["refine"] > 0:
            cf = refine_cut(bins_, valid, n, cf, g["refine"], window, c.bins, seen, ring_old,
                            first, left, right)
        rec.update(frame=int(cf), stage="after")
        if c.min_contrast > 0:
            if seen - cf < window:
                return
            con = contrast_at(bins_, valid, n, cf, g["contrast"], c.bins, seen,
                              max(ring_old, st["last_frame"]), left, right)
            rec.update(stage="contrast", con=float(con))
            if con < c.min_contrast:
                return
        if contrast2 > 0:
            con = contrast_at(bins_, valid, n, cf, contrast2, c.bins, seen,
                              max(ring_old, st["last_frame"]), left, right)
            if con < min_contrast2:
                return
        if min_seg and cf - max(0, st["last_frame"]) < min_seg:
            return
        if novelty > 0:
            # the before side is the whole current segment, the after side clipped to seen
            seg0 = max(ring_old, st["last_frame"], 0)
            a, b = cum[cf] - cum[seg0], cum[min(cf + g["contrast"], seen)] - cum[cf]
            den = np.sqrt(float(a @ a) * float(b @ b))
            rec.update(stage="novelty", nov=1.0 - float(a @ b) / den if den else 0.0)
            if den == 0 or 1.0 - float(a @ b) / den < novelty:
                return
        if recur > 0:
            # the current segment (round 7), or the last recur_lookback frames whatever the cuts
            seg0 = max(st["last_frame"], 0) if recur_lookback <= 0 else max(cf - recur_lookback, 0)
            after = (cum[cf + window] - cum[cf]).astype(np.float64)
            starts = src.centres[i] - window // 2
            starts = starts[(starts >= seg0) & (starts + window <= cf)]
            if starts.size:
                past = (cum[starts + window] - cum[starts]).astype(np.float64)
                den = np.sqrt((past * past).sum(1) * float(after @ after))
                dist = np.where(den > 0, 1.0 - (past @ after) / np.where(den > 0, den, 1), 1.0)
                rec.update(stage="recur", recur=float(dist.min()))
                if dist.min() < recur:
                    return
        if seg_contrast > 0:
            seg0 = max(st["last_frame"], 0)
            starts = src.centres[i] - window // 2
            inside = np.flatnonzero((starts >= seg0) & (starts + window <= cf))
            lag = -(-window // step)
            if inside.size > lag:
                s0 = starts[inside[:-lag]]
                s1 = starts[inside[lag:]]
                ok = s1 - s0 == lag * step  # one window length apart (no dropped window)
                a = (cum[s0 + window] - cum[s0]).astype(np.float64)[ok]
                b = (cum[s1 + window] - cum[s1]).astype(np.float64)[ok]
                den = np.sqrt((a * a).sum(1) * (b * b).sum(1))
                dist = np.where(den > 0, 1.0 - (a * b).sum(1) / np.where(den > 0, den, 1), 0.0)
                if dist.size:
                    own = contrast_at(bins_, valid, n, cf, window, c.bins, seen, ring_old,
                                      left, right)
                    rec.update(stage="segcon", segcon=float(own), segmax=float(dist.max()))
                    if own < seg_contrast * dist.max():
                        return
        if min_energy is not None:
            b0 = max(ring_old, st["last_frame"], cf - g["contrast"], 0)
            a1 = min(cf + g["contrast"], seen)
            bm, am = (b0 + cf) // 2, (cf + a1) // 2

            def dist(x, y, z):
                return span_contrast(bins_, valid, n, x, y, z, c.bins, left, right)

            e = dist(b0, cf, a1) - 0.5 * (dist(b0, bm, cf) + dist(cf, am, a1))
            rec.update(stage="energy", energy=float(e))
            if e < min_energy:
                return
        if confirm is not None:
            j = int(np.searchsorted(confirm.seen, seen, side="right")) - 1
            if j < 0:
                return
            cv, cc = confirm.lof[j], confirm.centres[j]
            near = np.abs(cc - cf) <= confirm_r
            if not near.any():
                return
            thr2 = robust_threshold(cv, cv.shape[0], confirm_mads, np.empty(cv.shape[0]))
            if cv[near].max() < max(c.min_score, thr2):
                return
        rec["stage"] = "cut"
        st["last_frame"] = cf
        st["last_seq"] = w
        st["cut_ws"].append(w)
        cuts.append(cf)
        lats.append(emitted - cf)

    for i in range(len(snaps.seq)):
        seq, seen = int(snaps.seq[i]), int(snaps.seen[i])
        one(seq - delay, seq, i, seen, seen - 1)
    if len(snaps.seq):
        i = len(snaps.seq) - 1
        last, size = int(snaps.seq[i]), snaps.lof[i].shape[0]
        for w in range(max(last - size + 1, last - delay + 1), last + 1):
            one(w, last, i, n, n - 1)
    return cuts, lats


def merge_causal(detections, gap):
    """Cuts of several detectors ``[(cuts, lats), ...]`` merged in emission order: a cut within
    ``gap`` frames of one already emitted is dropped (so the union is itself causal)."""
    events = sorted((c + lat, c, lat) for cuts, lats in detections for c, lat in zip(cuts, lats))
    out, out_lat = [], []
    for _, c, lat in events:
        if all(abs(c - o) >= gap for o in out):
            out.append(c)
            out_lat.append(lat)
    order = np.argsort(out, kind="stable")
    return [out[i] for i in order], [out_lat[i] for i in order]
