"""Repetition counting on other labs' capture systems: UI-PRMD Vicon and Kinect, RepCount-A pose.

Material (``../shared/data`` by default, ``--data DIR``; READMEs there give provenance):

* UI-PRMD (``uiprmd/``): ten exercises x subjects s01-s05, correct and incorrect executions,
  ten repetitions a take, the same takes from Vicon markers (TRC, 100 Hz) and Kinect v2 joints
  (CSV, 30 Hz). A take's first N repetitions (N = 2, 3, 4, 6, 10) are a set: the take cut
  at the end of its N-th repetition, from its first frame.
* RepCount-A pose (``repcount_pose/``): 30 test videos of stu1-stu3 as MediaPipe landmarks
  (min-max normalised per frame; NaN where no person), about 30 fps; a video's count is every
  repetition found in it, against the annotated count (nMAE over videos with a count > 0).

The counter runs as ``segment --method rep`` does (:class:`RepetitionSegmenter`, the file read
by streamseg's readers). Leave-one-subject-out: the parameters are chosen on the subjects of
:data:`CHOSEN_ON` only; rows over the others are marked held-out. ``--choose`` re-runs the
choice of the defaults on every system's chosen-on recordings at once (with HDM05 bd:
:func:`choose`) and says whether it lands on the defaults.

Run: ``cd benchmarks && ../.venv/bin/python rep_systems.py [--system S] [--choose] [-v]``.

Columns as ``benchmarks/repetitions.py``: exact, off-by-one (OBO), nMAE (|found - true| /
true), alpha (eq. 15, repetitions matched by overlap). A UI-PRMD set's count is that of the
found set holding most of its frames; "split" counts the sets found in more than one set.
"""

from __future__ import annotations

import csv
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

from streamseg.config import RepetitionConfig
from streamseg.evaluation.metrics import matched_repetition_accuracy

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
#: The subjects any parameter for these systems was chosen on; every other is held out.
CHOSEN_ON = {"vicon": ("s01",), "kinect": ("s01",), "repcount": ("stu1",)}
SIZES = (2, 3, 4, 6, 10)
EXERCISES = {
    "m01": "deep squat",
    "m02": "hurdle step",
    "m03": "inline lunge",
    "m04": "side lunge",
    "m05": "sit to stand",
    "m06": "straight leg raise",
    "m07": "shoulder abduction",
    "m08": "shoulder extension",
    "m09": "shoulder rotation",
    "m10": "shoulder scaption",
}


def _summary(rows):
    """(n, exact, OBO, nMAE, alpha) of rows (true, found, alpha); nMAE over true > 0."""
    k = np.array([r[0] for r in rows], float)
    c = np.array([r[1] for r in rows], float)
    pos = k > 0
    nmae = float(np.mean(np.abs(c[pos] - k[pos]) / k[pos])) if pos.any() else float("nan")
    return (
        len(rows),
        float(np.mean(c == k)),
        float(np.mean(np.abs(c - k) <= 1)),
        nmae,
        float(np.mean([r[2] for r in rows])),
    )


def _row(name, rows):
    n, e, o, m, a = _summary(rows)
    return f"| {name} | {n} | {e:.2f} | {o:.2f} | {m:.3f} | {a:.3f} |"


def _segment(rec, cfg):
    from streamseg.offline.repetition import RepetitionSegmenter

    return RepetitionSegmenter(cfg).fit(rec)


def uiprmd_takes(data, modality):
    """``{file: (subject, movement, execution, [(start, end), ...])}`` (0-based, end
    exclusive) of one modality."""
    takes = {}
    with open(data / "uiprmd" / "repetitions.csv", newline="") as fh:
        for r in csv.DictReader(fh):
            if r["modality"] != modality:
                continue
            t = takes.setdefault(r["file"], (r["subject"], r["movement"], r["execution"], []))
            t[3].append((int(r["start_frame"]) - 1, int(r["end_frame"])))
    return takes


def read_take(data, file, modality):
    from streamseg.io import read

    path = data / "uiprmd" / file
    return read(path, fps=30.0) if modality == "kinect" else read(path)


def run_uiprmd(data, modality, cfg, sizes=SIZES, log=None):
    """Per set: dict(subject, movement, execution, size, count, alpha, n_sets, reason)."""
    out = []
    for file, (subj, mov, exe, reps) in sorted(uiprmd_takes(data, modality).items()):
        rec = read_take(data, file, modality)
        for n in sizes:
            truth = reps[:n]
            seg = _segment(rec.slice(0, truth[-1][1]), cfg)
            found = [s["repetitions"] for s in seg.sets_]
            count, alpha = _score_set(found, truth)
            out.append(
                {
                    "file": file,
                    "subject": subj,
                    "movement": mov,
                    "execution": exe,
                    "size": n,
                    "count": count,
                    "alpha": alpha,
                    "n_sets": len(found),
                    "reason": seg.reason_,
                }
            )
        if log:
            log(f"{file}: " + " ".join(f"{r['count']}/{r['size']}" for r in out[-len(sizes) :]))
    return out


def _score_set(found, truth):
    """(count, alpha) of the found set that holds most of the true repetitions' frames."""
    if not found:
        return 0, 0.0
    inside = [sum(max(0, min(b, truth[-1][1]) - max(a, truth[0][0])) for a, b in s) for s in found]
    best = found[int(np.argmax(inside))]
    return len(best), matched_repetition_accuracy(best, truth)


def uiprmd_table(results, system, modality):
    chosen = CHOSEN_ON[modality]
    held = [r for r in results if r["subject"] not in chosen]
    rows = lambda rs: [(r["size"], r["count"], r["alpha"]) for r in rs]  # noqa: E731
    lines = [
        f"\n{system}",
        "",
        "| rows | sets | exact | OBO | nMAE | alpha |",
        "|---|---|---|---|---|---|",
    ]
    for k in sorted({r["size"] for r in held}):
        lines.append(_row(f"held-out, {k} repetitions", rows([r for r in held if r["size"] == k])))
    for m in sorted({r["movement"] for r in held}):
        lines.append(
            _row(f"held-out, {m} {EXERCISES[m]}", rows([r for r in held if r["movement"] == m]))
        )
    for e in ("correct", "incorrect"):
        lines.append(
            _row(f"held-out, {e} executions", rows([r for r in held if r["execution"] == e]))
        )
    for s in sorted({r["subject"] for r in held}):
        lines.append(_row(f"held-out subject {s}", rows([r for r in held if r["subject"] == s])))
    lines.append(
        _row(f"**held-out ({', '.join(sorted({r['subject'] for r in held}))})**", rows(held))
    )
    mine = [r for r in results if r["subject"] in chosen]
    if mine:
        lines.append(_row(f"{', '.join(chosen)} (parameters chosen here)", rows(mine)))
    split = sum(r["n_sets"] > 1 for r in held)
    zero = sum(r["count"] == 0 for r in held)
    lines.append(
        f"\nheld-out sets found split into several sets: {split} of {len(held)}; counted 0: {zero}"
    )
    return "\n".join(lines)


def repcount_videos(data):
    """``{file: (person, class, count, [(start, end), ...])}`` (0-based, end exclusive)."""
    vids = {}
    with open(data / "repcount_pose" / "repetitions.csv", newline="") as fh:
        for r in csv.DictReader(fh):
            v = vids.setdefault(
                r["file"], (Path(r["file"]).stem.split("_")[0], r["class"], int(r["count"]), [])
            )
            if r["start_frame"]:
                v[3].append((int(r["start_frame"]) - 1, int(r["end_frame"])))
    return vids


def run_repcount(data, cfg, log=None):
    from streamseg.io import read

    out = []
    for file, (person, cls, count, reps) in sorted(repcount_videos(data).items()):
        rec = read(data / "repcount_pose" / file, fps=30.0, joints="blazepose")
        seg = _segment(rec, cfg)
        found = [r for s in seg.sets_ for r in s["repetitions"]]
        alpha = matched_repetition_accuracy(found, reps) if reps else float(not found)
        nan = float(np.mean(~np.isfinite(rec.positions).all(axis=(1, 2))))
        out.append(
            {
                "file": file,
                "subject": person,
                "class": cls,
                "true": count,
                "count": len(found),
                "alpha": alpha,
                "n_sets": len(seg.sets_),
                "no_person": nan,
                "reason": seg.reason_,
            }
        )
        if log:
            log(f"{file} {cls}: {len(found)}/{count} in {len(seg.sets_)} sets")
    return out


def repcount_table(results):
    chosen = CHOSEN_ON["repcount"]
    held = [r for r in results if r["subject"] not in chosen]
    rows = lambda rs: [(r["true"], r["count"], r["alpha"]) for r in rs]  # noqa: E731
    lines = [
        "\nRepCount-A test videos, MediaPipe pose",
        "",
        "| rows | videos | exact | OBO | nMAE | alpha |",
        "|---|---|---|---|---|---|",
    ]
    for c in sorted({r["class"] for r in held}):
        lines.append(_row(f"held-out, {c}", rows([r for r in held if r["class"] == c])))
    lines.append(
        _row(
            "held-out, > 20% frames without a person",
            rows([r for r in held if r["no_person"] > 0.2]),
        )
        if any(r["no_person"] > 0.2 for r in held)
        else "| held-out, > 20% frames without a person | 0 | | | | |"
    )
    for s in sorted({r["subject"] for r in held}):
        lines.append(_row(f"held-out person {s}", rows([r for r in held if r["subject"] == s])))
    lines.append(
        _row(f"**held-out ({', '.join(sorted({r['subject'] for r in held}))})**", rows(held))
    )
    mine = [r for r in results if r["subject"] in chosen]
    if mine:
        lines.append(_row(f"{', '.join(chosen)} (parameters chosen here)", rows(mine)))
    n_sets = sum(r["n_sets"] for r in held)
    lines.append(f"\nheld-out: {n_sets} sets found over {len(held)} videos")
    return "\n".join(lines)


class ChosenOn:
    """The recordings every parameter is chosen on: each system's :data:`CHOSEN_ON` subjects
    and HDM05 bd (``benchmarks/repetitions.py``), read once."""

    def __init__(self, data):
        import repetitions as H  # beside this file

        from streamseg.io import read

        self.uiprmd = {
            m: [
                (read_take(data, f, m), t[3])
                for f, t in sorted(uiprmd_takes(data, m).items())
                if t[0] in CHOSEN_ON[m]
            ]
            for m in ("vicon", "kinect")
        }
        self.repcount = [
            (read(data / "repcount_pose" / f, fps=30.0, joints="blazepose"), v[2], v[3])
            for f, v in sorted(repcount_videos(data).items())
            if v[0] in CHOSEN_ON["repcount"]
        ]
        self.hdm05 = H.Material(actors=(H.CHOOSE_ON,))

    def objective(self, cfg) -> tuple:
        """(objective, per-system summaries): Vicon and Kinect exact + alpha over their sets,
        RepCount-A OBO - nMAE + alpha, HDM05 bd's objective (exact + alpha on its sets of
        2-6 + the share of its routine sets counted right)."""
        import repetitions as H

        out, total = {}, 0.0
        for m, takes in self.uiprmd.items():
            rows = []
            for rec, reps in takes:
                for n in SIZES:
                    seg = _segment(rec.slice(0, reps[n - 1][1]), cfg)
                    rows.append((n, *_score_set([x["repetitions"] for x in seg.sets_], reps[:n])))
            out[m] = _summary(rows)
            total += out[m][1] + out[m][4]
        rows = []
        for rec, count, reps in self.repcount:
            found = [r for st in _segment(rec, cfg).sets_ for r in st["repetitions"]]
            rows.append(
                (
                    count,
                    len(found),
                    matched_repetition_accuracy(found, reps) if reps else float(not found),
                )
            )
        out["repcount"] = _summary(rows)
        total += out["repcount"][2] - out["repcount"][3] + out["repcount"][4]
        bd = H.objective(*H.evaluate(self.hdm05, cfg, (H.CHOOSE_ON,)))
        out["hdm05 bd"] = bd
        return total + bd, out


def choose(data, log=print):
    """Coordinate ascent from the defaults (chosen on HDM05 bd alone) over
    ``repetitions.GRID`` and the low-rate low-pass, each value of each parameter in turn, a
    change kept when it raises :meth:`ChosenOn.objective` (every system's chosen-on
    recordings), rounds until one keeps nothing; returns the config."""
    from dataclasses import replace

    import repetitions as H

    grid = {**H.GRID, "lowpass_low_rate_hz": (2.0, 2.5, 3.0, 3.5)}
    mat = ChosenOn(data)
    cfg = RepetitionConfig()
    best, _ = mat.objective(cfg)
    log(f"start (the defaults): {best:.4f}")
    changed = True
    while changed:
        changed = False
        for name, values in grid.items():
            for v in values:
                if v == getattr(cfg, name):
                    continue
                trial = replace(cfg, **{name: v})
                score, _ = mat.objective(trial)
                log(f"  {name}={v}: {score:.4f}")
                if score > best + 1e-9:
                    best, cfg, changed = score, trial, True
    chosen = {k: getattr(cfg, k) for k in grid}
    now = {k: getattr(RepetitionConfig(), k) for k in grid}
    log(
        f"chosen: {chosen} (objective {best:.4f}); "
        f"{'the defaults' if chosen == now else 'NOT the defaults ' + str(now)}"
    )
    return cfg


def main(argv=None):
    import argparse
    import sys

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=SHARED, help=f"default {SHARED}")
    ap.add_argument("--system", choices=("vicon", "kinect", "repcount", "all"), default="all")
    ap.add_argument(
        "--sizes",
        default=",".join(map(str, SIZES)),
        help="UI-PRMD set sizes (first N repetitions of each take)",
    )
    ap.add_argument("-v", "--verbose", action="store_true", help="one line per take")
    ap.add_argument(
        "--choose",
        action="store_true",
        help="re-run the choice of the defaults on every system's chosen-on "
        "recordings first (about ten minutes)",
    )
    args = ap.parse_args(argv)
    if args.choose:
        choose(args.data)
    cfg = RepetitionConfig()
    sizes = tuple(int(x) for x in args.sizes.split(","))
    log = (lambda s: print(s, file=sys.stderr, flush=True)) if args.verbose else None
    t0 = time.perf_counter()
    if args.system in ("vicon", "all"):
        res = run_uiprmd(args.data, "vicon", cfg, sizes, log)
        print(uiprmd_table(res, "UI-PRMD Vicon markers (TRC, 100 Hz)", "vicon"))
        _reasons(res)
    if args.system in ("kinect", "all"):
        res = run_uiprmd(args.data, "kinect", cfg, sizes, log)
        print(uiprmd_table(res, "UI-PRMD Kinect v2 joints (CSV, 30 Hz)", "kinect"))
        _reasons(res)
    if args.system in ("repcount", "all"):
        print(repcount_table(run_repcount(args.data, cfg, log)))
    print(f"\n({time.perf_counter() - t0:.0f} s)", file=sys.stderr)


def _reasons(results):
    """The reasons given for sets counted 0, most frequent first."""
    why = defaultdict(int)
    for r in results:
        if r["count"] == 0:
            why[r["reason"].split("(")[0].strip()] += 1
    for k, v in sorted(why.items(), key=lambda kv: -kv[1]):
        print(f"- counted 0, {v} sets: {k}")


if __name__ == "__main__":
    main()
