"""Live relabelling against offline HACA: the real daemon over loopback, scored on human labels.

For each labelled recording (sets cmu, cmu02 and hdm of ``eval --all data``:
CMU 86_01, 14_14 and 14_20, the two CMU 02 joins, the nine HDM05 joins; the joins are abrupt,
not natural transitions) this starts the daemon in this process on free loopback ports, replays the
recording as a live stream (``--speeds``, times real time), and collects every ``segments``
event. The live answer is, for every frame, the label of the newest revision covering it
(what a listener that applies each revision holds at the end). It is scored against the human
labels, beside offline HACA run in the same process on the same features (the daemon's 17
cut features), once with K found and once given the true K:

* ``acc``: Hungarian-matched frame accuracy (each cluster to at most one human action);
* ``ari``: adjusted Rand index (scikit-learn);
* ``K``: distinct labels of the live answer / of offline HACA (K found) / true.

The daemon runs with its defaults (``DaemonConfig()``, ``ACAConfig()``) unless
``--history``, ``--interval`` or ``--[no-]label-memory`` are given. Relabelling needs no K:
it is found per revision.

Run: .venv/bin/python benchmarks/live_relabel.py [--speeds 1,4] [--only 86_01,hdm_bd_0]
     (real time for every recording: about 8 minutes; --speeds 4: about 2 minutes)
"""

from __future__ import annotations

import argparse
import threading
from dataclasses import replace

import numpy as np
from _common import labelled

from streamseg.config import ACAConfig, DaemonConfig
from streamseg.evaluation.metrics import matched_frame_accuracy


def recordings():
    """name -> (Recording, per-frame human label ids): the sets cmu, cmu02 and hdm of
    ``eval --all data``."""
    return {i.name: (i.recording, i.frame_labels) for i in labelled(("cmu", "cmu02", "hdm"))}


def ari(a, b) -> float:
    from sklearn.metrics import adjusted_rand_score

    return float(adjusted_rand_score(a, b))


def live(rec, stream, speed, config, algorithms=None, revisions=None):
    """Replay ``rec`` into a fresh daemon; the per-frame labels of the newest revisions.

    ``algorithms``: the daemon's (default: its own); ``revisions``: a list that receives every
    revision as ``(start, end, segments)``."""
    from streamseg.client import listen, subscriber
    from streamseg.commands.replay import replay
    from streamseg.daemon import Daemon

    daemon = Daemon(replace(config, heartbeat=0.05), algorithms)
    ep = daemon.bind()
    server = threading.Thread(target=daemon.run, daemon=True)
    server.start()
    daemon.ready.wait()
    sub = subscriber(ep["publish"])
    # handshake: the first heartbeat shows the subscription has reached the publisher
    next(e for e in listen(sub, timeout=30) if e.type == "stats")
    events = []

    def collect():
        events.extend(
            e
            for e in listen(sub, stream=stream, until_end=True, timeout=120)
            if getattr(e, "stream", None) == stream
        )

    t = threading.Thread(target=collect, daemon=True)
    t.start()
    replay(rec, ep["ingest"], stream=stream, speed=speed, batch=max(1, int(4 * speed)))
    t.join(180)
    daemon.stop()
    server.join(30)
    sub.close()
    n = rec.n_frames
    lab = np.full(n, -1)
    revs = [e for e in events if e.type == "segments"]
    for ev in revs:
        for a, b, c in ev.segments:
            lab[a : min(b, n)] = c
        segs = [(int(a), min(int(b), n), int(c)) for a, b, c in ev.segments if a < n]
        if revisions is not None and segs:
            revisions.append((min(a for a, _, _ in segs), max(b for _, b, _ in segs), segs))
    times = [e.elapsed for e in revs]
    return lab, len(revs), times


def offline(features, fps, k):
    from streamseg.offline.model_selection import fit_aca

    cfg = replace(ACAConfig(), n_clusters=k)
    return fit_aca(features, cfg, fps).labels_


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--speeds", default="1,4")
    ap.add_argument("--only", default="")
    ap.add_argument("--history", type=float, default=None)
    ap.add_argument("--interval", type=float, default=None)
    ap.add_argument(
        "--label-memory",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="the daemon's exemplar memory (default: DaemonConfig's)",
    )
    args = ap.parse_args()
    speeds = [float(s) for s in args.speeds.split(",")]
    loop = "tcp://127.0.0.1:0"
    over = {}
    if args.history is not None:
        over["relabel_history"] = args.history
    if args.interval is not None:
        over["relabel_interval"] = args.interval
    if args.label_memory is not None:
        over["label_memory"] = args.label_memory
    config = DaemonConfig(ingest=loop, publish=loop, control=loop, heartbeat=0, **over)
    recs = recordings()
    if args.only:
        recs = {k: v for k, v in recs.items() if k in args.only.split(",")}
    print(
        f"daemon: relabel every {config.relabel_interval:g} s over the last "
        f"{config.relabel_history:g} s; label memory {config.label_memory}; ACA: {ACAConfig()}"
    )
    print(
        "| recording | speed | live acc | live ari | offline HACA acc (K found) | ari | "
        "HACA acc (K true) | K live / found / true | revisions | relabel s med |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    from streamseg.skeleton import bone_angles

    rows = []
    for name, (rec, truth) in recs.items():
        feats = bone_angles(rec.positions, rec.skeleton, inclinations=True).astype(np.float32)
        feats = feats.astype(np.float64)  # the daemon keeps float32 features
        k_true = int(np.unique(truth[truth >= 0]).size)
        off = offline(feats, rec.fps, None)
        off_true = offline(feats, rec.fps, k_true)
        keep = truth >= 0
        a_off = matched_frame_accuracy(off[keep], truth[keep])[0]
        a_true = matched_frame_accuracy(off_true[keep], truth[keep])[0]
        for speed in speeds:
            lab, n_rev, times = live(rec, name, speed, config)
            ok = keep & (lab >= 0)
            a_live = matched_frame_accuracy(lab[keep], truth[keep])[0]
            row = dict(
                name=name,
                speed=speed,
                live=a_live,
                live_ari=ari(truth[ok], lab[ok]),
                off=a_off,
                off_ari=ari(truth[keep], off[keep]),
                true=a_true,
                k_live=int(np.unique(lab[lab >= 0]).size),
                k_off=int(np.unique(off).size),
                k_true=k_true,
            )
            rows.append(row)
            med = f"{np.median(times):.2f}" if times else "-"
            print(
                f"| {name} | {speed:g}x | {a_live:.3f} | {row['live_ari']:.3f} | {a_off:.3f} | "
                f"{row['off_ari']:.3f} | {a_true:.3f} | {row['k_live']} / {row['k_off']} / "
                f"{k_true} | {n_rev} | {med} |",
                flush=True,
            )
    print()
    for speed in speeds:
        r = [x for x in rows if x["speed"] == speed]
        gap = [x["off"] - x["live"] for x in r]
        kgap = [x["true"] - x["off"] for x in r]
        print(
            f"{speed:g}x: mean live acc {np.mean([x['live'] for x in r]):.3f}, offline HACA "
            f"(K found) {np.mean([x['off'] for x in r]):.3f}, HACA (K true) "
            f"{np.mean([x['true'] for x in r]):.3f}; live within 0.03 of offline on "
            f"{sum(g <= 0.03 for g in gap)}/{len(r)} (worst gap {max(gap):.3f}); K found "
            f"within 0.03 of K true on {sum(g <= 0.03 for g in kgap)}/{len(r)} (worst "
            f"{max(kgap):.3f}); K found == K true on "
            f"{sum(x['k_off'] == x['k_true'] for x in r)}/{len(r)}"
        )


if __name__ == "__main__":
    main()
