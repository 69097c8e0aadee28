"""Stream-wide ids for actions that return after the relabel history: no memory vs the
label memory (:mod:`streamseg.offline.label_memory`, :mod:`streamseg.offline.recall`).

Streams: :func:`streamseg.evaluation.datasets.return_streams`: CMU takes and HDM05 clips
joined (ABRUPT joins) so that actions come back more than 60 s after they were last seen.
Each stream is relabelled as the daemon does (``streamseg.daemon.pipeline.relabel``, the
daemon's job function): every ``--interval`` s of stream time over the last ``--history`` s,
plus a final revision at the end, each revision's ids carried from the previous one. This
"revisions" mode runs the same job function as the daemon but without the daemon's
transport, live cuts (no boundary snapping) or skipped revisions; ``--daemon SPEED`` instead
runs the real daemon over loopback at SPEED times real time (``benchmarks/live_relabel.py``).

The final live segmentation (for every frame, the newest revision covering it) is scored
against the human action names over the WHOLE stream: Hungarian frame accuracy (a returning
action that gets a new id is a second cluster, matched to nothing or to another action, so it
is penalised), and ``returning``: of the frames of actions seen again after a gap longer than
the history, the share whose id is the id their action had most at its first occurrence;
``recalls true:false``: occurrences of an id after a gap longer than the history (only the
memory joins those) whose majority action is / is not the one of the id's first occurrence
(false: a new or other action given an old id); ``ids of 2+ actions``: ids whose runs of 1 s
or more are mostly of different actions (false recalls, or the overlap handing an id on).

``--grid`` sweeps the recall's settings on the two tuning streams (ret_14_86_14, ret_hdm_bd)
only, the window fits computed once per stream (the memory never changes them).

``--overhead`` times a revision with its window fit cached: what the memory adds.

Run: .venv/bin/python benchmarks/label_memory.py [--only ret_14_86_14] [--daemon 1] [--grid]
     [--overhead]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from streamseg.config.memory import LabelMemoryConfig  # noqa: E402
from streamseg.daemon.pipeline import Algorithms, relabel  # noqa: E402
from streamseg.evaluation.datasets import return_streams  # noqa: E402
from streamseg.evaluation.metrics import matched_frame_accuracy  # noqa: E402
from streamseg.skeleton import bone_angles  # noqa: E402


def simulate(feats, fps, algorithms, interval, history):
    """Per-frame labels of the newest revision covering each frame; revision timings."""
    n = feats.shape[0]
    step, span = int(round(interval * fps)), int(round(history * fps))
    ends = list(range(step, n, step)) + [n]
    lab = np.full(n, -1)
    previous, times, nbytes = None, [], 0
    for t in ends:
        s = max(0, t - span)
        frames = np.arange(s, t, dtype=np.int64)
        res = relabel(algorithms, feats[s:t], frames, fps, previous)
        previous = res.window
        times.append(res.elapsed)
        mem = getattr(previous, "memory", None)
        nbytes = max(nbytes, mem.nbytes if mem is not None else 0)
        for a, b, c in res.segments:
            lab[a:b] = c
    return lab, times, nbytes


class FitCache:
    """``relabel_window`` with its fits kept per window (the memory never changes a window's
    fit, so a stream's fits are computed once for every memory setting)."""

    def __init__(self):
        self.fits = {}

    def __call__(self, features, *, start_frame, fps, config, previous=None):
        from streamseg.offline import relabel_window

        key = (int(start_frame), int(features.shape[0]))
        if key not in self.fits:
            self.fits[key] = relabel_window(features, start_frame=start_frame, fps=fps,
                                            config=config, previous=previous)
        return self.fits[key]


def recalls(lab, names, fps, history):
    """Occurrences of an id after a gap longer than the history (only the memory joins
    them): ``(true, false, false frames)``; true when the occurrence's majority action is the
    one of the id's first occurrence, false (a new or other action given an old id) else."""
    good = bad = bad_frames = 0
    for i in np.unique(lab[lab >= 0]):
        idx = np.flatnonzero(lab == i)
        cuts = np.flatnonzero(np.diff(idx) > history * fps) + 1
        occ = np.split(idx, cuts)
        if len(occ) < 2:
            continue
        vals, cnt = np.unique(names[occ[0]], return_counts=True)
        first = vals[cnt.argmax()]
        for o in occ[1:]:
            vals, cnt = np.unique(names[o], return_counts=True)
            if vals[cnt.argmax()] == first:
                good += 1
            else:
                bad += 1
                bad_frames += o.size
    return good, bad, bad_frames


def mixed_ids(lab, names, fps, min_s=1.0):
    """Ids whose runs of at least ``min_s`` seconds are mostly of two or more different human
    actions (an id that means two actions: a false recall, or the overlap handing an id on)."""
    edges = np.flatnonzero(np.diff(lab)) + 1
    starts, ends = np.r_[0, edges], np.r_[edges, lab.size]
    actions: dict = {}
    for a, b in zip(starts, ends, strict=True):
        if lab[a] < 0 or b - a < min_s * fps:
            continue
        vals, cnt = np.unique(names[a:b], return_counts=True)
        actions.setdefault(int(lab[a]), set()).add(vals[cnt.argmax()])
    return sum(len(v) > 1 for v in actions.values())


def returning_share(lab, names, fps, history):
    """Share of frames of returning actions (back after a gap > history) whose id is the one
    their action held most at its first occurrence; and how many such frames."""
    ok, total = 0, 0
    for name in np.unique(names):
        idx = np.flatnonzero(names == name)
        if idx.size == 0 or name == "":
            continue
        gaps = np.flatnonzero(np.diff(idx) > history * fps)
        if gaps.size == 0:
            continue
        first = idx[:gaps[0] + 1]
        later = idx[gaps[0] + 1:]
        first_id = np.bincount(lab[first][lab[first] >= 0]).argmax()
        ok += int((lab[later] == first_id).sum())
        total += later.size
    return (ok / total if total else float("nan")), total


def daemon_labels(rec, name, speed, memory, history, interval):
    from benchmarks.live_relabel import live
    from streamseg.config import DaemonConfig

    loop = "tcp://127.0.0.1:0"
    cfg = DaemonConfig(ingest=loop, publish=loop, control=loop, heartbeat=0,
                       relabel_history=history, relabel_interval=interval,
                       label_memory=memory)
    lab, n_rev, times = live(rec, name, speed, cfg)
    return lab, times, 0  # the daemon's memory size is not read here ("-")


TRAIN = ("ret_14_86_14", "ret_hdm_bd")  # the declared tuning streams (held: the other three)


def score(lab, truth, names, fps, history, times, nbytes):
    acc = matched_frame_accuracy(lab, truth)[0]
    ret, n_ret = returning_share(lab, names, fps, history)
    good, bad, bad_frames = recalls(lab, names, fps, history)
    return dict(acc=acc, ret=ret, n_ret=n_ret, ids=len(np.unique(lab[lab >= 0])),
                good=good, bad=bad, bad_s=bad_frames / fps, mixed=mixed_ids(lab, names, fps),
                med=float(np.median(times)) if times else 0.0, kb=nbytes / 1e3)


def grid(streams, args):
    """Every setting of the recall on the given (tuning) streams, fits shared."""
    settings = [dict(recall_ratio=r, recall_margin=m, recall_confirm=c, recall_within=w)
                for r in (0.3, 0.4, 0.5, 0.6, 0.7, 1.0) for m in (0.0, 0.1, 0.2)
                for c, w in ((1, 1), (1, 2), (1, 3), (2, 3))]
    print("| setting | " + " | ".join(f"{n} acc / ret / recalls true:false" for n in streams)
          + " | mean acc |")
    print("|---|" + "---|" * (len(streams) + 1))
    data = {}
    for name, (rec, names) in streams.items():
        feats = bone_angles(rec.positions, rec.skeleton, inclinations=True).astype(np.float32)
        data[name] = (feats.astype(np.float64), rec.fps, names, FitCache())
    base = {}
    for name, (feats, fps, names, cache) in data.items():
        lab, times, nb = simulate(feats, fps, Algorithms(relabel=cache), args.interval,
                                  args.history)
        _, truth = np.unique(names, return_inverse=True)
        base[name] = score(lab, truth, names, fps, args.history, times, nb)
    print("| no memory | " + " | ".join(
        f"{b['acc']:.3f} / {b['ret']:.3f} / {b['good']}:{b['bad']}" for b in base.values())
        + f" | {np.mean([b['acc'] for b in base.values()]):.3f} |", flush=True)
    for st in settings:
        cfg = LabelMemoryConfig(**st)
        row = []
        for feats, fps, names, cache in data.values():
            lab, times, nb = simulate(feats, fps, Algorithms(relabel=cache, memory_config=cfg),
                                      args.interval, args.history)
            _, truth = np.unique(names, return_inverse=True)
            row.append(score(lab, truth, names, fps, args.history, times, nb))
        tag = ", ".join(f"{k.removeprefix('recall_')} {v:g}" for k, v in st.items())
        print(f"| {tag} | " + " | ".join(
            f"{b['acc']:.3f} / {b['ret']:.3f} / {b['good']}:{b['bad']}" for b in row)
            + f" | {np.mean([b['acc'] for b in row]):.3f} |", flush=True)


def overhead(streams, args):
    """Per-revision time of the job function with the window fits cached (computed by a first
    pass), so what is left is identity matching, the recall and the memory update."""
    print("| stream | revisions | job s median no / memory | job s max no / memory |")
    print("|---|---|---|---|")
    for name, (rec, _) in streams.items():
        feats = bone_angles(rec.positions, rec.skeleton, inclinations=True).astype(np.float32)
        feats = feats.astype(np.float64)
        cache = FitCache()
        simulate(feats, rec.fps, Algorithms(relabel=cache), args.interval, args.history)
        t = {}
        for mem in (False, True):
            algos = Algorithms(relabel=cache, memory_config=LabelMemoryConfig() if mem else None)
            t[mem] = simulate(feats, rec.fps, algos, args.interval, args.history)[1]
        print(f"| {name} | {len(t[True])} | {np.median(t[False]) * 1e3:.1f} ms / "
              f"{np.median(t[True]) * 1e3:.1f} ms | {np.max(t[False]) * 1e3:.1f} ms / "
              f"{np.max(t[True]) * 1e3:.1f} ms |", flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="")
    ap.add_argument("--history", type=float, default=60.0)
    ap.add_argument("--interval", type=float, default=5.0)
    ap.add_argument("--daemon", type=float, default=0.0, help="real daemon at this speed")
    ap.add_argument("--grid", action="store_true",
                    help="sweep the recall settings on the tuning streams only")
    ap.add_argument("--overhead", action="store_true",
                    help="time of a revision without the window fit (fits cached)")
    args = ap.parse_args()
    streams = return_streams(ROOT / "data")
    if args.overhead:
        return overhead(streams, args)
    if args.grid:
        return grid({k: streams[k] for k in TRAIN}, args)
    if args.only:
        streams = {k: v for k, v in streams.items() if k in args.only.split(",")}
    mode = (f"real daemon at {args.daemon:g}x" if args.daemon else "revisions (job function)")
    print(f"{mode}; relabel every {args.interval:g} s over the last {args.history:g} s; "
          f"memory {LabelMemoryConfig()}")
    print("| stream | split | s | K true | acc no / memory | returning no / memory | "
          "ids no / memory | recalls true:false (false s) | ids of 2+ actions no / memory | "
          "relabel s med no / memory | memory kB |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    rows = []
    for name, (rec, names) in streams.items():
        feats = bone_angles(rec.positions, rec.skeleton, inclinations=True).astype(np.float32)
        feats = feats.astype(np.float64)
        _, truth = np.unique(names, return_inverse=True)
        out = {}
        for mem in (False, True):
            if args.daemon:
                lab, times, nb = daemon_labels(rec, name, args.daemon, mem, args.history,
                                               args.interval)
            else:
                algos = Algorithms(memory_config=LabelMemoryConfig() if mem else None)
                lab, times, nb = simulate(feats, rec.fps, algos, args.interval, args.history)
            out[mem] = score(lab, truth, names, rec.fps, args.history, times, nb)
        a, b = out[False], out[True]
        rows.append((a, b))
        print(f"| {name} | {'tuning' if name in TRAIN else 'held out'} | "
              f"{rec.n_frames / rec.fps:.0f} | {len(np.unique(truth))} | "
              f"{a['acc']:.3f} / {b['acc']:.3f} | {a['ret']:.3f} / {b['ret']:.3f} | "
              f"{a['ids']} / {b['ids']} | {a['good']}:{a['bad']} / {b['good']}:{b['bad']} "
              f"({b['bad_s']:.1f}) | {a['mixed']} / {b['mixed']} | "
              f"{a['med']:.2f} / {b['med']:.2f} | "
              f"{'-' if args.daemon else format(b['kb'], '.0f')} |",
              flush=True)
    print()
    print(f"mean acc no memory {np.mean([a['acc'] for a, _ in rows]):.3f}, memory "
          f"{np.mean([b['acc'] for _, b in rows]):.3f}; mean returning no memory "
          f"{np.nanmean([a['ret'] for a, _ in rows]):.3f}, memory "
          f"{np.nanmean([b['ret'] for _, b in rows]):.3f}")


if __name__ == "__main__":
    main()
