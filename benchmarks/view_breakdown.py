"""What the consumer's view gets wrong 3 and 10 s after each true boundary, per recording, and
where each wrong boundary came from.

Reads the events of a ``consumer_view.py --save`` file and builds the same view as
:func:`consumer_view.view_at`, remembering which event put each boundary there: a label change
of a ``segments`` revision, a ``cut`` announced with ``provisional: false``, a provisional
``cut`` not yet settled, or a cut a ``confirm`` settled after the newest revision covering it.
Per recording: the F1 of the view at 3 s, 10 s and the end (as ``consumer_view.py``), the true
boundaries known at 3 s but no longer at 10 s, and the view's false boundaries (none of the
true ones within the tolerance) at each true boundary's 3 s and 10 s moment, by source.

Run: .venv/bin/python benchmarks/consumer_view.py --sets cmu,cmu02,hdm --save EV.jsonl
     .venv/bin/python benchmarks/view_breakdown.py EV.jsonl [--only a,b] [--tolerance 1.5]
"""

from __future__ import annotations

import argparse
import bisect
import collections

import consumer_view as cv
from _common import labelled, markdown_table

SOURCES = ("revision", "announced cut", "provisional cut", "confirmed cut")


def view_sources(events, t: float) -> dict:
    """The view after the events published at or before ``t``: frame -> source (one of
    :data:`SOURCES`); the rules of :func:`consumer_view.view_at`."""
    cuts: dict = {}
    revision: list = []  # sorted boundaries of the revisions
    for when, ev in events:
        if when > t:
            break
        if ev.type == "cut":
            cuts[ev.frame] = "provisional cut" if ev.provisional else "announced cut"
        elif ev.type == "withdraw":
            cuts.pop(ev.frame, None)
        elif ev.type == "confirm":
            settled = getattr(ev, "settled", None)
            if settled is not None and ev.frame in cuts:
                del cuts[ev.frame]
                cuts[settled] = "confirmed cut"
        elif ev.type == "segments":
            a, b = ev.start, ev.end
            for f in [f for f in cuts if a < f < b]:
                del cuts[f]
            lo, hi = bisect.bisect_right(revision, a), bisect.bisect_left(revision, b)
            segs = cv._triples(ev.segments)
            new = [int(s[0]) for p, s in zip(segs[:-1], segs[1:]) if p[2] != s[2]]
            revision[lo:hi] = [f for f in new if a < f < b]
    out = dict.fromkeys(revision, "revision")
    out.update(cuts)  # a cut on a revision's boundary: the cut's event came later
    return out


def breakdown(events, truth, fps: float, tol_s: float) -> tuple:
    """(lost, false): the true boundaries (frames) known at 3 s and not at 10 s; a Counter of
    ``(delay, source)`` of the false boundaries of the view at each true boundary's moment."""
    events = sorted(events, key=lambda e: e[0])
    tol = tol_s * fps
    lost, false = [], collections.Counter()
    for b in truth:
        views = {d: view_sources(events, b + d * fps) for d in (3.0, 10.0)}
        known = {d: any(abs(f - b) <= tol for f in v) for d, v in views.items()}
        if known[3.0] and not known[10.0]:
            lost.append(b)
        for d, v in views.items():
            for f, src in v.items():
                if not any(abs(f - x) <= tol for x in truth):
                    false[(d, src)] += 1
    return lost, false


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("events", help="a consumer_view.py --save file")
    p.add_argument("--only", default="", help="comma-separated recording names (default: all)")
    p.add_argument("--tolerance", type=float, default=1.5)
    args = p.parse_args(argv)
    saved = cv._saved(args.events)
    items = {i.name: i for i in labelled(("cmu", "cmu02", "hdm")) + cv.heldout()}
    names = [n for n in args.only.split(",") if n] or [n for n in items if n in saved]
    header = ["recording", "F1 3 s / 10 s / end", "true", "known at 3 s, lost by 10 s"]
    header += [f"false at {d}: " + " / ".join(SOURCES) for d in ("3 s", "10 s")]
    rows, total, n_true, n_lost = [], collections.Counter(), 0, 0
    for name in names:
        item = items[name]
        fps = float(item.recording.fps)
        events, n = saved[name]
        res = cv.score_view(events, n, item.cuts, fps, args.tolerance)
        lost, false = breakdown(events, list(item.cuts), fps, args.tolerance)
        total.update(false)
        n_true, n_lost = n_true + len(item.cuts), n_lost + len(lost)
        f1 = " / ".join(f"{res[k][2]:.3f}" for k in (3.0, 10.0, "end"))
        lost_s = ", ".join(f"{b / fps:.1f} s" for b in lost) or "-"
        rows.append([name, f1, len(item.cuts), lost_s] + _counts(false))
    rows.append(["all", "", n_true, n_lost] + _counts(total))
    print(markdown_table(header, rows))


def _counts(false) -> list:
    return [" / ".join(str(false[(d, s)]) for s in SOURCES) for d in (3.0, 10.0)]


if __name__ == "__main__":
    main()
