"""streamseg beside the segmenters people already use, on every labelled recording.

Usage: bash benchmarks/peers.sh [--runs 3] [--only NAME ...] [--markdown FILE] [--plot PNG]

(`peers.sh` makes `.venv-peers` with the `peers` extra: claspy 0.2.8 pins an older numpy,
numba and scikit-learn than streamseg's own environment, so the peers get a venv of their own
and streamseg runs there too, unchanged, on the same feature matrices.)

Every method sees the same feature matrix per recording: streamseg's default LOF bone features
per frame, the paper's 8 bone angles and the 9 bones' inclinations from the up axis
(``streamseg.offline.lof.lof_features`` with ``root_speed_max=0``), at the recording's 120 Hz;
streamseg's own LOF rows also read their 2 root-speed columns (since issue 11 round 14; the
table in docs/peers_table.md predates them). Methods that need one
signal (stumpy FLUSS/FLOSS, streaming ClaSP) get its first principal component. Parameters
that are chosen (Pelt's penalty, FLOSS's threshold) are chosen on CMU 86_01 only and held for
the rest; methods given the true number of cuts (KernelCPD, FLUSS) or of actions (ACA, HACA)
say so in their name.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from streamseg.evaluation.corpus import (
    STREAMSEG_METHODS,
    LabelledRecording,
    Prediction,
    discover,
    evaluate_all,
    format_table,
    score,
    segments_from_cuts,
)
from streamseg.evaluation.datasets import CMU02_SEQUENCES, cmu02_sequence
from streamseg.offline.lof import lof_features

DATA = Path(__file__).resolve().parents[1] / "data"
TRAIN = "86_01"  # the one recording parameters are chosen on


def labelled_recordings() -> list[LabelledRecording]:
    """86_01, the CMU exercise routines, and two sequences joined from CMU subject 02 clips."""
    items = discover(DATA, skeleton=DATA / "cmu86/86.asf")
    for name, trials in CMU02_SEQUENCES.items():
        rec, cuts = cmu02_sequence(DATA, trials)
        items.append(
            LabelledRecording(
                name,
                rec,
                segments_from_cuts(cuts, rec.n_frames),
                "CMU 02 clips joined: abrupt joins",
            )
        )
    return items


def first_pc(x: np.ndarray) -> np.ndarray:
    """Projection on the first principal component of standardized features, shape (n,)."""
    z = (x - x.mean(0)) / np.maximum(x.std(0), 1e-12)
    _, _, vt = np.linalg.svd(z, full_matrices=False)
    return np.ascontiguousarray(z @ vt[0])


# --- peers -----------------------------------------------------------------------------------


def kernelcpd(x, n_cuts, fps):
    import ruptures

    algo = ruptures.KernelCPD(kernel="rbf", min_size=int(fps)).fit(x)
    return Prediction(cuts=algo.predict(n_bkps=n_cuts)[:-1]) if n_cuts else Prediction()


PELT_JUMP = 10  # frames between candidate change points: keeps Pelt's rbf cost affordable


def pelt(x, pen, fps):
    import ruptures

    return Prediction(
        cuts=ruptures.Pelt(model="rbf", min_size=int(fps), jump=PELT_JUMP)
        .fit(x)
        .predict(pen=pen)[:-1]
    )


def fluss(signal, n_cuts, fps):
    import stumpy

    m = int(fps)  # one-second subsequences
    mp = stumpy.stump(signal, m)
    _, regimes = stumpy.fluss(mp[:, 1].astype(np.int64), L=m, n_regimes=n_cuts + 1, excl_factor=1)
    return Prediction(cuts=sorted(int(r) for r in np.atleast_1d(regimes)))


def floss_trace(signal, fps, window_s=10.0, check_every=12):
    """Run FLOSS over a sliding window; every ``check_every`` frames record the lowest point of
    the corrected arc curve away from the window's edges: ``(t, frame, value)`` rows."""
    import stumpy

    m, w = int(fps), int(window_s * fps)
    if len(signal) <= w:
        return np.zeros((0, 3))
    stream = stumpy.floss(stumpy.stump(signal[:w], m), signal[:w], m=m, L=m, excl_factor=1)
    rows, edge = [], m
    for t in range(w, len(signal)):
        stream.update(signal[t])
        if (t - w) % check_every == 0:
            cac = stream.cac_1d_
            i = edge + int(np.argmin(cac[edge:-edge]))
            rows.append((t, t + 1 - w + i, cac[i]))  # window start + subsequence index
    return np.array(rows)


def floss(trace, threshold, fps):
    """Streaming FLOSS decisions from a :func:`floss_trace`: a cut when the arc curve's
    minimum dips below ``threshold``, at least 2 s after the previous cut."""
    cuts, lat = [], []
    for t, frame, value in trace:
        if value < threshold and (not cuts or frame - cuts[-1] > 2 * fps):
            cuts.append(int(frame))
            lat.append(int(t - frame))
    return Prediction(cuts=cuts, latencies=lat)


def clasp(x, fps):
    from claspy.segmentation import BinaryClaSPSegmentation

    return Prediction(cuts=[int(c) for c in BinaryClaSPSegmentation().fit_predict(x)])


def clasp_stream(signal, fps):
    from claspy.streaming.segmentation import StreamingClaSPSegmentation

    model = StreamingClaSPSegmentation(
        n_timepoints=int(30 * fps), n_warmup=int(5 * fps), log_cps=True
    )
    cuts, lat = [], []
    for t, v in enumerate(signal):
        model.update(float(v))
        while len(model.change_points) > len(cuts):
            cp = int(model.change_points[len(cuts)])
            cuts.append(cp)
            lat.append(t - cp)
    return Prediction(cuts=cuts, latencies=lat)


def choose(train: LabelledRecording, fps, make, grid):
    """The grid value with the best F1 on the training recording."""
    x = angles(train)
    return max(grid, key=lambda v: score(train, make(x, v), fps)["F1"])


def angles(item):
    """The bone features (17 columns); streamseg's LOF rows add their 2 root speeds."""
    from streamseg.config import LOFConfig

    return lof_features(item.recording, LOFConfig(root_speed_max=0))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3, help="timed runs per method (median)")
    ap.add_argument("--only", nargs="*", help="run only methods whose name contains one of these")
    ap.add_argument("--markdown", help="also write the table to this file")
    ap.add_argument("--plot", help="timeline PNG for CMU 86_01: labels and each method's cuts")
    args = ap.parse_args()
    items = labelled_recordings()
    train = next(i for i in items if i.name == TRAIN)
    fps = train.recording.fps
    t0 = time.perf_counter()
    pen = choose(train, fps, lambda x, v: pelt(x, v, fps), [1, 2, 5, 10, 20, 50, 80, 120])
    trace = floss_trace(first_pc(angles(train)), fps)
    thr = choose(train, fps, lambda x, v: floss(trace, v, fps), [0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9])
    print(
        f"chosen on {TRAIN}: Pelt penalty {pen}, FLOSS threshold {thr} "
        f"({time.perf_counter() - t0:.0f} s)",
        file=sys.stderr,
    )
    methods = {f"streamseg {k}": v for k, v in STREAMSEG_METHODS.items()}
    methods.update(
        {
            "ruptures KernelCPD (n=true)": lambda it, f: kernelcpd(angles(it), len(it.cuts), f),
            f"ruptures Pelt (pen={pen})": lambda it, f: pelt(angles(it), pen, f),
            "stumpy FLUSS (n=true)": lambda it, f: fluss(first_pc(angles(it)), len(it.cuts), f),
            f"stumpy FLOSS (thr={thr})": lambda it, f: floss(
                floss_trace(first_pc(angles(it)), f), thr, f
            ),
            "claspy ClaSP": lambda it, f: clasp(angles(it), f),
            "claspy streaming ClaSP": lambda it, f: clasp_stream(first_pc(angles(it)), f),
        }
    )
    if args.only:
        methods = {k: v for k, v in methods.items() if any(o in k for o in args.only)}
    rows, preds = evaluate_all(items, methods, args.runs)
    table = format_table(rows)
    print(table)
    if args.markdown:
        Path(args.markdown).write_text(table + "\n")
    if args.plot:
        from streamseg.plotting.timeline import timeline

        shown = [
            (m, preds[(TRAIN, m)].cuts, preds[(TRAIN, m)].labels)
            for m in methods
            if not preds[(TRAIN, m)].error
        ]
        timeline(
            args.plot,
            train.recording.n_frames,
            fps,
            [(s.start, s.end, s.label) for s in train.segments],
            shown,
            title=f"CMU {TRAIN}: human labels and each method's cuts",
        )


if __name__ == "__main__":
    main()
