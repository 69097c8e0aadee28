"""Scoring segmenters on labelled recordings: discovery, one row per (recording, method), a table.

Used by ``streamseg eval --all DIR`` and by ``benchmarks/peers.py``, so both print the same
measures computed the same way.
"""

from __future__ import annotations

import csv
import math
import statistics
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from streamseg.evaluation.labels import (
    LabelSegment,
    cut_windows,
    frame_labels,
    read_labels,
    true_cuts,
)
from streamseg.evaluation.metrics import covering, cut_scores, latency_stats, matched_frame_accuracy
from streamseg.exceptions import RecordingError

LABEL_HEADER = ["sequence", "start_frame", "end_frame", "action_label"]
RECORDING_SUFFIXES = (".amc.gz", ".amc", ".bvh", ".c3d", ".trc", ".npz")


@dataclass
class LabelledRecording:
    """A recording with human segments.

    Attributes
    ----------
    name : str
    recording : Recording
    segments : list of LabelSegment
        0-based, end exclusive; ``lo``/``hi`` are each cut's acceptance window.
    note : str
        How the sequence was made (e.g. "concatenated clips: joins are abrupt").
    group : str
        The set it belongs to (``streamseg.evaluation.labelled_sets``); "" when none.
    """

    name: str
    recording: object
    segments: list
    note: str = ""
    group: str = ""

    @property
    def cuts(self) -> list[int]:
        return true_cuts(self.segments, self.recording.n_frames)

    @property
    def windows(self) -> list[tuple[int, int]]:
        return cut_windows(self.segments)[: len(self.cuts)]

    @property
    def frame_labels(self) -> np.ndarray:
        return frame_labels(self.segments, self.recording.n_frames)

    @property
    def n_actions(self) -> int:
        return len({s.label for s in self.segments})


def segments_from_cuts(cuts, n_frames: int, label: str = "part") -> list[LabelSegment]:
    """Label segments for a sequence whose only truth is its cut frames (e.g. joined clips)."""
    bounds = [0, *sorted(int(c) for c in cuts), n_frames]
    return [
        LabelSegment(a, b, f"{label}{i}", b, b)
        for i, (a, b) in enumerate(zip(bounds[:-1], bounds[1:]))
    ]


def discover(folder, skeleton=None, markers=None) -> list[LabelledRecording]:
    """Every recording under ``folder`` named by a label CSV beside it.

    A CSV counts as labels when its header starts ``sequence,start_frame,end_frame,
    action_label``; each of its sequences must have a recording ``<sequence>.amc[.gz]``,
    ``.bvh``, ``.c3d``, ``.trc`` or ``.npz`` in the same folder. An AMC uses the one ``.asf``
    in its folder, else ``skeleton``; C3D and TRC markers use the marker map ``markers``
    (``--markers MAP.toml``) when given.

    Raises
    ------
    RecordingError
        When a labelled sequence has no recording or an AMC has no skeleton.
    """
    from streamseg.io import read

    folder = Path(folder)
    if not folder.is_dir():
        raise RecordingError(folder, None, "not a folder", "a folder holding label CSVs")
    out = []
    for csv_path in sorted(folder.rglob("*.csv")):
        try:
            with csv_path.open(newline="", encoding="utf-8") as fh:
                header = next(csv.reader(fh), [])
                if header[:4] != LABEL_HEADER:
                    continue
                sequences = list(dict.fromkeys(row[0] for row in csv.reader(fh) if row))
        except UnicodeDecodeError:
            continue  # not text, so not a label CSV (a label CSV that is: read_labels says)
        asfs = sorted(csv_path.parent.glob("*.asf"))
        for seq in sequences:
            path = next(
                (
                    csv_path.parent / f"{seq}{s}"
                    for s in RECORDING_SUFFIXES
                    if (csv_path.parent / f"{seq}{s}").exists()
                ),
                None,
            )
            if path is None:
                raise RecordingError(
                    csv_path,
                    None,
                    f"sequence {seq!r} without a recording",
                    f"{seq}.amc[.gz], .bvh or .npz beside the labels",
                )
            skel = asfs[0] if len(asfs) == 1 else skeleton
            rec = read(
                path,
                skeleton=skel,
                markers=markers if path.suffix.lower() in (".c3d", ".trc") else None,
            )
            out.append(
                LabelledRecording(seq, rec, read_labels(csv_path, seq), f"labels: {csv_path.name}")
            )
    return out


@dataclass
class Prediction:
    """What a method says about one recording.

    Attributes
    ----------
    cuts : list of int
    labels : ndarray of int, shape (n_frames,), or None
        Per-frame cluster ids, for methods that label.
    latencies : list of int or None
        Frames between each cut and the frame at which it was emitted (streaming methods).
    seconds : float
        Median wall time.
    error : str
        Why the method could not run (then the other fields are empty).
    """

    cuts: list = field(default_factory=list)
    labels: np.ndarray | None = None
    latencies: list | None = None
    seconds: float = float("nan")
    error: str = ""


def timed(fn, runs: int = 3) -> tuple:
    """``(result of the last run, median seconds over runs)``."""
    times, result = [], None
    for _ in range(runs):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return result, statistics.median(times)


def score(item: LabelledRecording, pred: Prediction, fps: float) -> dict:
    """One table row: P/R/F1 (label window widened by 0.5 s, and a flat 1 s), covering,
    Hungarian frame accuracy (labelling methods), latency (streaming methods), time."""
    n = item.recording.n_frames
    if pred.error:
        return {"error": pred.error}
    win = cut_scores(pred.cuts, item.cuts, windows=item.windows, margin=round(0.5 * fps))
    flat = cut_scores(pred.cuts, item.cuts, tolerance=round(1.0 * fps))
    row = {
        "P": win["precision"],
        "R": win["recall"],
        "F1": win["f1"],
        "F1@1s": flat["f1"],
        "cover": covering(pred.cuts, item.cuts, n),
        "n_cuts": len(pred.cuts),
        "acc": float("nan"),
        "lat_med": float("nan"),
        "lat_max": float("nan"),
        "time_s": pred.seconds,
    }
    if pred.labels is not None:
        row["acc"] = matched_frame_accuracy(pred.labels, item.frame_labels)[0]
    if pred.latencies is not None:
        lat = latency_stats(pred.latencies)
        row["lat_med"], row["lat_max"] = lat["median"], lat["max"]
    return row


COLUMNS = ("P", "R", "F1", "F1@1s", "cover", "acc", "lat_med", "lat_max", "time_s", "n_cuts")
#: the table's short column names -> the keys of the JSON rows (docs/output.md), as ``eval``
JSON_KEYS = {
    "P": "precision",
    "R": "recall",
    "F1": "f1",
    "F1@1s": "f1_1s",
    "cover": "covering",
    "acc": "accuracy",
    "lat_med": "latency_median_frames",
    "lat_max": "latency_max_frames",
    "time_s": "seconds",
    "n_cuts": "n_cuts",
    "error": "error",
}


def json_row(row: dict) -> dict:
    """A :func:`score` row with the key names of ``eval --json`` (NaN -> null when dumped)."""
    return {JSON_KEYS.get(k, k): v for k, v in row.items()}


def table_row(row: dict) -> dict:
    """Inverse of :func:`json_row`: a JSON row back under the table's column names."""
    short = {v: k for k, v in JSON_KEYS.items()}
    return {short.get(k, k): v for k, v in row.items()}


def format_table(rows: list[tuple[str, str, dict]], means: bool = True) -> str:
    """Markdown table of ``(recording, method, row)``; with ``means``, a per-method mean block."""

    def cell(v):
        if isinstance(v, float):
            return "" if math.isnan(v) else f"{v:.3f}" if abs(v) < 100 else f"{v:.0f}"
        return str(v)

    head = "| recording | method | " + " | ".join(COLUMNS) + " |"
    lines = [head, "|" + "---|" * (len(COLUMNS) + 2)]
    for rec, method, row in rows:
        if "error" in row:
            lines.append(f"| {rec} | {method} | could not run: {row['error']} |")
        else:
            lines.append(
                f"| {rec} | {method} | " + " | ".join(cell(row[c]) for c in COLUMNS) + " |"
            )
    if means:
        methods = list(dict.fromkeys(m for _, m, _ in rows))
        for m in methods:
            ok = [r for _, mm, r in rows if mm == m and "error" not in r]
            if not ok:
                continue
            avg = {}
            for c in COLUMNS:
                vals = [r[c] for r in ok if not (isinstance(r[c], float) and math.isnan(r[c]))]
                avg[c] = float(np.mean(vals)) if vals else float("nan")
            lines.append(
                f"| **mean ({len(ok)})** | {m} | "
                + " | ".join(cell(avg[c]) for c in COLUMNS)
                + " |"
            )
    return "\n".join(lines)


class Progress:
    """A progress bar on stderr: redrawn in place on a terminal, one line per step in a log."""

    def __init__(self, total: int, width: int = 30, stream=None):
        self.total, self.done, self.width = max(total, 1), 0, width
        self.stream = stream or sys.stderr
        self.tty = getattr(self.stream, "isatty", lambda: False)()
        self.t0 = time.perf_counter()

    def step(self, what: str = "") -> None:
        self.done += 1
        filled = int(self.width * self.done / self.total)
        elapsed = time.perf_counter() - self.t0
        line = (
            f"[{'#' * filled}{'.' * (self.width - filled)}] {self.done}/{self.total} "
            f"{elapsed:5.0f}s {what[:40]}"
        )
        if self.tty:
            end = "\n" if self.done >= self.total else ""
            self.stream.write(f"\r{line:<{self.width + 60}}{end}")
        else:
            self.stream.write(line + "\n")
        self.stream.flush()


# --- streamseg's own methods, as `eval --all` and the peers benchmark run them ---------------


def _angles(item: LabelledRecording) -> np.ndarray:
    """The default cut detector's features (8 bone angles + 9 inclinations + 2 root
    speeds), (n, 19)."""
    from streamseg.offline.lof import lof_features

    return lof_features(item.recording)


def _bone_features(item: LabelledRecording) -> np.ndarray:
    """The bone features alone (8 bone angles + 9 inclinations), (n, 17): what the daemon's
    relabels cluster."""
    from streamseg.config import LOFConfig
    from streamseg.offline.lof import lof_features

    return lof_features(item.recording, LOFConfig(root_speed_max=0))


def lof_prediction(angles: np.ndarray, fps: float, online: bool, config=None) -> Prediction:
    """LOF cuts of a feature matrix (``config``'s features; None: the defaults), offline or
    streamed in 120-frame packets."""
    from streamseg.config import LOFConfig
    from streamseg.offline.lof_report import lof_report

    res = lof_report(angles, fps, config or LOFConfig(), online)
    return Prediction(cuts=list(res["cuts"]), latencies=res["latency"] if online else None)


def label_cuts(labels: np.ndarray) -> list[int]:
    """Frames where a per-frame labelling changes: the cuts of a clustering."""
    labels = np.asarray(labels)
    return [int(i) for i in np.flatnonzero(labels[1:] != labels[:-1]) + 1]


def aca_prediction(
    features: np.ndarray, n_clusters: int | None, fps: float, hierarchical: bool, config=None
) -> Prediction:
    """(H)ACA (``config``; None: the defaults) with ``n_clusters`` actions (None: found): frame
    labels and their cuts."""
    from dataclasses import replace

    from streamseg.config import ACAConfig
    from streamseg.offline.model_selection import fit_aca

    config = replace(config or ACAConfig(), n_clusters=n_clusters, hierarchical=hierarchical)
    labels = np.asarray(fit_aca(features, config, fps).labels_)
    return Prediction(cuts=label_cuts(labels), labels=labels)


# Every method sees the cut detector's bone features (8 bone angles + 9 inclinations), as
# the daemon does (a live stream carries positions only); LOF also its 2 root speeds. ACA
# labels them better than the 8 angles alone or joint quaternions (docs/decisions.md, Labels).
STREAMSEG_METHODS = {
    "LOF offline": lambda item, fps: lof_prediction(_angles(item), fps, False),
    "LOF streaming": lambda item, fps: lof_prediction(_angles(item), fps, True),
    "ACA (K=true)": lambda item, fps: aca_prediction(
        _bone_features(item), item.n_actions, fps, False
    ),
    "HACA (K=true)": lambda item, fps: aca_prediction(
        _bone_features(item), item.n_actions, fps, True
    ),
    "HACA (K found)": lambda item, fps: aca_prediction(_bone_features(item), None, fps, True),
}


def evaluate_all(items, methods: dict, runs: int = 3) -> tuple[list, dict]:
    """Run every method on every item; a method that fails is reported, not hidden.

    Parameters
    ----------
    items : list of LabelledRecording
    methods : dict of name -> callable(item, fps) -> Prediction
    runs : int
        Timed runs per method and item (median wall time).

    Returns
    -------
    rows : list of (recording name, method name, row dict) for :func:`format_table`
    predictions : dict of (recording name, method name) -> Prediction
    """
    rows, preds = [], {}
    bar = Progress(len(items) * len(methods))
    for item in items:
        fps = item.recording.fps
        for name, run in methods.items():
            try:
                pred, sec = timed(lambda run=run, item=item, fps=fps: run(item, fps), runs)
                pred.seconds = sec
            except Exception as err:  # reported in the table with its error
                pred = Prediction(error=f"{type(err).__name__}: {err}"[:160])
            rows.append((item.name, name, score(item, pred, fps)))
            preds[(item.name, name)] = pred
            bar.step(f"{item.name} {name}")
    return rows, preds
