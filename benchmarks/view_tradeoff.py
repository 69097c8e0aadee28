"""The decision latency against the consumer's view: the cut detector's settings (window,
look-ahead, localisation radius, step, the early stage) each run through
``consumer_view.py`` (in-process, on stream time), and the choice among them by
leave-one-out.

For each setting of :data:`SETTINGS`: the view's F1 at 1, 3, 10 s after each true boundary
and at the end, and the median latency from a true boundary to its first ``cut`` event, on
the two recordings choices are made on (``--chosen-on``) and on the other recordings of
``--sets``. Then leave-one-out over every recording of ``--sets`` among the settings marked
for it: each recording is scored with the setting that the other recordings choose, by the
rule of docs/decisions.md (The decision latency): the highest mean of ``J`` (a recording's F1
at 3 s, 10 s and the end, averaged), and among settings within 0.005 of it the lowest median
latency.

Run: .venv/bin/python benchmarks/view_tradeoff.py [--save-dir D | --load-dir D]
(``--save-dir`` keeps each setting's events, ``--load-dir`` scores kept ones without running.)
"""

from __future__ import annotations

import argparse
import collections
import os
import statistics

import consumer_view as cv
from _common import markdown_table

#: (consumer_view options, whether the leave-one-out chooses among it); "" is the defaults
SETTINGS = (
    ("", True),
    ("--early 1.0", False),
    ("--early 1.2", True),
    ("--delay 1.2", False),
    ("--delay 1.8", False),
    ("--window 1.5 --delay 1.2", True),
    ("--window 1.25 --delay 1.2", True),
    ("--window 1.25 --delay 1.2 --refine 0.2", True),
    ("--window 1.25 --delay 1.0", False),
    ("--window 1.0 --delay 1.0", False),
    ("--window 1.0 --delay 1.2", True),
    ("--window 1.0 --delay 1.2 --refine 0.2", True),
    ("--window 0.75 --delay 1.2 --refine 0.2", True),
    ("--step 0.1 --delay 0.8", False),
    ("--step 0.1 --k 10 --delay 1.2", False),
)
NEAR = 0.005  # J within this of the best: the lower latency wins


def _slug(opts: str) -> str:
    return opts.replace("--", "").replace(" ", "_") or "defaults"


def results(args) -> dict:
    """Setting -> recording name -> (J, F1 3 s, F1 10 s, F1 end, F1 1 s, latencies, group)."""
    out = {}
    for opts, _ in SETTINGS:
        argv = ["--sets", args.sets, *opts.split()]
        directory = args.load_dir or args.save_dir
        if directory:
            path = os.path.join(directory, _slug(opts) + ".jsonl")
            if args.load_dir and not os.path.exists(path):
                continue
            if args.save_dir and os.path.exists(path):
                os.remove(path)  # --save appends
            argv += ["--load" if args.load_dir else "--save", path]
        rows = cv.run(cv.parser().parse_args(argv))
        out[opts] = {
            r["name"]: (
                statistics.mean(r[k][2] for k in (3.0, 10.0, "end")),
                r[3.0][2],
                r[10.0][2],
                r["end"][2],
                r[1.0][2],
                r["latency"],
                r["group"],
            )
            for r in rows
        }
    return out


def _mean(rows, k) -> str:
    return f"{statistics.mean(r[k] for r in rows):.3f}"


def _latency(rows) -> float:
    lat = [x for r in rows for x in r[5]]
    return statistics.median(lat) if lat else float("nan")


def curve(res, chosen) -> str:
    header = ["setting"]
    header += [f"chosen on: F1 {d}" for d in ("1 s", "3 s", "10 s", "end")] + ["latency med s"]
    header += [f"the other {{}}: F1 {d}" for d in ("3 s", "10 s", "end")] + ["latency med s"]
    rows, n_other = [], 0
    for opts, d in res.items():
        pair = [v for n, v in d.items() if n in chosen]
        other = [v for n, v in d.items() if n not in chosen]
        n_other = len(other)
        cells = [f"`{opts}`" if opts else "defaults"]
        cells += [_mean(pair, k) for k in (4, 1, 2, 3)] + [f"{_latency(pair):.2f}"]
        cells += [_mean(other, k) for k in (1, 2, 3)] + [f"{_latency(other):.2f}"]
        rows.append(cells)
    header = [h.format(n_other) for h in header]
    return markdown_table(header, rows)


def leave_one_out(res) -> str:
    cands = [o for o, loo in SETTINGS if loo and o in res]
    names = sorted(set.intersection(*(set(res[o]) for o in cands)))
    choice = {}
    for out in names:
        rest = [n for n in names if n != out]
        score = {o: statistics.mean(res[o][n][0] for n in rest) for o in cands}
        best = max(score.values())
        near = [o for o in cands if score[o] >= best - NEAR]
        choice[out] = min(near, key=lambda o: _latency([res[o][n] for n in rest]))
    votes = collections.Counter(choice.values())
    header = ["scored with", "folds", "J", "F1 3 s", "F1 10 s", "F1 end", "latency med s"]
    header += ["hdm F1 10 s / end"]
    rows = []
    for label, pick in [("each fold's choice", choice)] + [
        (f"`{o}`" if o else "defaults", dict.fromkeys(names, o)) for o in cands
    ]:
        got = [res[pick[n]][n] for n in names]
        hdm = [v for v in got if v[6] == "hdm"]
        folds = len(names) if label == "each fold's choice" else votes.get(pick[names[0]], 0)
        cells = [label, folds] + [_mean(got, k) for k in range(4)] + [f"{_latency(got):.2f}"]
        cells.append(f"{_mean(hdm, 2)} / {_mean(hdm, 3)}" if hdm else "-")
        rows.append(cells)
    return markdown_table(header, rows)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sets", default="cmu,cmu02,hdm")
    p.add_argument("--chosen-on", default="86_01,hdm_bd_0")
    p.add_argument("--save-dir", default="")
    p.add_argument("--load-dir", default="")
    args = p.parse_args(argv)
    if args.save_dir:
        os.makedirs(args.save_dir, exist_ok=True)
    res = results(args)
    print(curve(res, set(args.chosen_on.split(","))))
    print()
    print(leave_one_out(res))


if __name__ == "__main__":
    main()
