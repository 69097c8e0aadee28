"""Scores of a consumer's view (:mod:`consumer_view`): the boundaries a consumer knows after
the events published by a moment, and recall, precision and F1 of that view 1, 3 and 10 s
after each true boundary and at the end; the first-cut latency; the detector's pending cuts
(how many, how many near a true boundary, against the share of the take near one).

The rules are in :mod:`consumer_view`'s docstring."""

from __future__ import annotations

import bisect

import numpy as np

DELAYS = (1.0, 3.0, 10.0)


class Views:
    """The view after each event, looked up by time (``events`` sorted by time)."""

    def __init__(self, events, cuts_only=False):
        self.times = [t for t, _ in events]
        self.views = [frozenset()]
        for i in range(len(events)):
            if i + 1 == len(events) or self.times[i + 1] != self.times[i]:
                self.views.append(frozenset(view_at(events[: i + 1], float("inf"), cuts_only)))
            else:
                self.views.append(None)
        # the view after the last event published at or before each time
        self.keys = [t for i, t in enumerate(self.times) if self.views[i + 1] is not None]
        self.vals = [v for v in self.views[1:] if v is not None]

    def at(self, t: float) -> frozenset:
        i = bisect.bisect_right(self.keys, t)
        return self.vals[i - 1] if i else frozenset()


def view_at(events, t: float, cuts_only: bool = False) -> list:
    """The consumer's boundaries after the events published at or before ``t`` (with
    ``cuts_only``: of the ``cut``, ``confirm`` and ``withdraw`` events alone)."""
    cuts: dict = {}  # frame -> settled (True: confirmed by a relabel or not provisional);
    # a revision supersedes both kinds inside its range, as a consumer applying it does
    revision: list = []  # sorted boundaries of the revisions
    for when, ev in events:
        if when > t:
            break
        kind = ev.type
        if kind == "cut":
            cuts[ev.frame] = not ev.provisional
        elif kind == "withdraw":
            cuts.pop(ev.frame, None)
        elif kind == "confirm":
            settled = getattr(ev, "settled", None)
            if settled is not None and ev.frame in cuts:
                del cuts[ev.frame]
                cuts[settled] = True
        elif kind == "segments" and not cuts_only:
            a, b = ev.start, ev.end
            for f in [f for f in cuts if a < f < b]:
                del cuts[f]
            lo, hi = bisect.bisect_right(revision, a), bisect.bisect_left(revision, b)
            segs = _triples(ev.segments)
            new = [int(s[0]) for p, s in zip(segs[:-1], segs[1:]) if p[2] != s[2]]
            revision[lo:hi] = [f for f in new if a < f < b]
    return sorted(set(revision) | set(cuts))


def _triples(segments) -> list:
    """``(start, end, label)`` of a ``segments`` event's list (``listen --jsonl`` writes each
    as a map)."""
    return [
        (s["start"], s["end"], s["label"]) if isinstance(s, dict) else tuple(s) for s in segments
    ]


def _near(frames, targets, tol) -> np.ndarray:
    """For each of ``frames``: whether one of ``targets`` lies within ``tol``."""
    if not len(frames):
        return np.zeros(0, dtype=bool)
    if not len(targets):
        return np.zeros(len(frames), dtype=bool)
    t = np.sort(np.asarray(targets))
    f = np.asarray(frames)
    i = np.clip(np.searchsorted(t, f), 1, len(t) - 1) if len(t) > 1 else np.zeros(len(f), int)
    d = np.minimum(np.abs(t[i] - f), np.abs(t[np.maximum(i - 1, 0)] - f))
    return d <= tol


def _f1(p, r) -> float:
    return 0.0 if p + r == 0 else 2 * p * r / (p + r)


def score_view(events, n, truth, fps, tol_s=1.5, cuts_only=False) -> dict:
    """Recall, precision and F1 at each of :data:`DELAYS` and at the end; first-cut latency."""
    events = sorted(events, key=lambda e: e[0])  # stable: publication order within a frame
    tol = tol_s * fps
    out = {}
    views = Views(events, cuts_only)
    for d in DELAYS:
        dt = d * fps
        rec, prec = [], []
        for b in truth:
            seen = sorted(views.at(b + dt))
            rec.append(bool(_near([b], seen, tol)[0]))
            if seen:
                prec.append(float(np.mean(_near(seen, truth, tol))))
        r = float(np.mean(rec)) if truth else 1.0
        p = float(np.mean(prec)) if prec else 1.0
        out[d] = (r, p, _f1(p, r))
    final = view_at(events, float("inf"), cuts_only)
    r = float(np.mean(_near(truth, final, tol))) if truth else 1.0
    p = float(np.mean(_near(final, truth, tol))) if final else 1.0
    out["end"] = (r, p, _f1(p, r))
    lat, lag = [], []
    for b in truth:
        first = [(t, ev) for t, ev in events if ev.type == "cut" and abs(ev.frame - b) <= tol]
        if first:
            t, ev = min(first, key=lambda x: x[0])
            lat.append((t - b) / fps)
            lag.append((t - ev.frame) / fps)
    out["latency"] = lat
    out["lag"] = lag
    out["unresolved"] = unresolved(events)
    out["pending"] = pending_cuts(events, truth, tol)
    frames = np.arange(n)
    out["near"] = float(np.mean(_near(frames, truth, tol))) if truth and n else 0.0
    return out


def pending_cuts(events, truth, tol) -> tuple:
    """The detector's pending cuts (``pending: true``): how many, and how many lie within
    ``tol`` frames of a true boundary."""
    frames = [ev.frame for _, ev in events if ev.type == "cut" and getattr(ev, "pending", None)]
    return len(frames), int(np.sum(_near(frames, truth, tol)))


def unresolved(events) -> int:
    """Provisional cuts no relabel confirmed or withdrew (a detector's own confirm of a
    pending cut does not settle it)."""
    open_ = set()
    for _, ev in events:
        if ev.type == "cut" and ev.provisional:
            open_.add(ev.frame)
        elif ev.type == "withdraw":
            open_.discard(ev.frame)
        elif ev.type == "confirm" and getattr(ev, "revision", None) is not None:
            open_.discard(ev.frame)
    return len(open_)
