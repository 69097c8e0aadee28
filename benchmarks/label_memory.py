"""Stream-wide ids for actions that return after the relabel history: no memory vs the
exemplar memory (:mod:`streamseg.offline.label_memory`).

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
the history, the share whose id is the id their action had most at its first occurrence.

Run: .venv/bin/python benchmarks/label_memory.py [--only ret_14_86_14] [--daemon 4]
"""

from __future__ import annotations

import argparse
import sys
import time
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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="")
    ap.add_argument("--history", type=float, default=60.0)
    ap.add_argument("--interval", type=float, default=5.0)
    ap.add_argument("--daemon", type=float, default=0.0, help="real daemon at this speed")
    args = ap.parse_args()
    streams = return_streams(ROOT / "data")
    if args.only:
        streams = {k: v for k, v in streams.items() if k in args.only.split(",")}
    mode = (f"real daemon at {args.daemon:g}x" if args.daemon else "revisions (job function)")
    print(f"{mode}; relabel every {args.interval:g} s over the last {args.history:g} s; "
          f"memory {LabelMemoryConfig()}")
    print("| stream | s | K true | acc no memory | acc memory | returning no memory | "
          "returning memory | ids no / memory | relabel s med no / memory | memory kB |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    rows = []
    for name, (rec, names) in streams.items():
        feats = bone_angles(rec.positions, rec.skeleton, inclinations=True).astype(np.float32)
        feats = feats.astype(np.float64)
        _, truth = np.unique(names, return_inverse=True)
        out = {}
        for mem in (False, True):
            t0 = time.perf_counter()
            if args.daemon:
                lab, times, nb = daemon_labels(rec, name, args.daemon, mem, args.history,
                                               args.interval)
            else:
                algos = Algorithms(memory_config=LabelMemoryConfig() if mem else None)
                lab, times, nb = simulate(feats, rec.fps, algos, args.interval, args.history)
            acc = matched_frame_accuracy(lab, truth)[0]
            ret, n_ret = returning_share(lab, names, rec.fps, args.history)
            out[mem] = dict(acc=acc, ret=ret, n_ret=n_ret, ids=len(np.unique(lab[lab >= 0])),
                            med=float(np.median(times)) if times else 0.0, kb=nb / 1e3,
                            wall=time.perf_counter() - t0)
        a, b = out[False], out[True]
        rows.append((a, b))
        print(f"| {name} | {rec.n_frames / rec.fps:.0f} | {len(np.unique(truth))} | "
              f"{a['acc']:.3f} | {b['acc']:.3f} | {a['ret']:.3f} | {b['ret']:.3f} | "
              f"{a['ids']} / {b['ids']} | {a['med']:.2f} / {b['med']:.2f} | "
              f"{'-' if args.daemon else format(b['kb'], '.0f')} |",
              flush=True)
    print()
    print(f"mean acc no memory {np.mean([a['acc'] for a, _ in rows]):.3f}, memory "
          f"{np.mean([b['acc'] for _, b in rows]):.3f}; mean returning no memory "
          f"{np.nanmean([a['ret'] for a, _ in rows]):.3f}, memory "
          f"{np.nanmean([b['ret'] for _, b in rows]):.3f}")


if __name__ == "__main__":
    main()
