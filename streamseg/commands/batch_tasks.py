"""A whole corpus through ``segment``, one task per recording: what ``streamseg batch`` runs.

Each task builds exactly the object ``streamseg segment --json`` prints (the method module's
``segment(args)``, :data:`streamseg.commands.METHODS`) and adds ``"file"``; with labels it also
scores it as ``eval --all`` does (:func:`streamseg.evaluation.score`). A task never raises:
a recording that cannot be segmented gives ``{"file", "error"}``, so one bad file in an
archive costs only itself. The tasks are plain picklable functions of paths and options, so
any executor runs them: the command uses a Dask cluster (:mod:`streamseg.commands.batch`).
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import glob
import importlib
import io
import os
import time
from pathlib import Path

from streamseg import strict_json
from streamseg.evaluation.corpus import LABEL_HEADER, RECORDING_SUFFIXES

MATRIX_SUFFIXES = (".npy", ".csv")


def expand(inputs) -> list[str]:
    """Recording paths from files, globs and folders, in the given order, each once.

    A folder contributes every recording under it (``.amc[.gz]``, ``.bvh``, ``.npz``,
    sorted); a file is taken as named (feature matrices ``.npy``/``.csv`` too); a pattern
    with ``* ? [`` is expanded here (also when the shell did not) and adds nothing when it
    matches nothing. A plain name that does not exist is kept, so its line says "no such
    file".
    """
    out = []
    for item in inputs:
        p = Path(item)
        if p.is_dir():
            found = [
                str(f)
                for f in sorted(p.rglob("*"))
                if f.is_file() and f.name.lower().endswith(RECORDING_SUFFIXES)
            ]
            out += found
        elif any(ch in item for ch in "*?[") and not p.exists():
            out += sorted(glob.glob(item, recursive=True))
        else:
            out.append(item)
    return list(dict.fromkeys(out))


def skeleton_for(path: str, given: str | None = None) -> str | None:
    """The ASF of an AMC, as ``eval --all`` finds it: the ``.asf`` beside it (or in an
    ``asf/`` folder beside it, or in its folder's parent) whose name starts the file's name
    (``86.asf`` for ``86_01.amc``, ``HDM_bd.asf`` for ``HDM_bd_hop...amc``), else the only
    one beside it, else ``given`` (``--skeleton``: for AMCs whose folder has none)."""
    if ".amc" not in Path(path).name.lower():
        return given
    name = Path(path).name
    here = Path(path).parent
    candidates = []
    for folder in (here, here / "asf", here.parent, here.parent / "asf"):
        if folder.is_dir():
            candidates += sorted(folder.glob("*.asf"))
    prefixed = [a for a in candidates if name.startswith(a.stem)]
    if prefixed:
        return str(max(prefixed, key=lambda a: len(a.stem)))
    beside = sorted(here.glob("*.asf"))
    return str(beside[0]) if len(beside) == 1 else given


def label_index(path) -> dict:
    """Sequence name -> label CSV, from one label CSV or every label CSV under a folder
    (a CSV counts when its header starts ``sequence,start_frame,end_frame,action_label``)."""
    from streamseg.exceptions import ParameterError

    p = Path(path)
    files = sorted(p.rglob("*.csv")) if p.is_dir() else [p]
    if not p.exists():
        raise ParameterError(f"--labels {path}: no such file or folder")
    index = {}
    for f in files:
        with f.open(newline="", encoding="utf-8") as fh:
            rows = csv.reader(fh)
            if next(rows, [])[:4] != LABEL_HEADER:
                continue
            for row in rows:
                if row:
                    index.setdefault(row[0], str(f))
    if not index:
        raise ParameterError(
            f"--labels {path}: no label CSV (header {','.join(LABEL_HEADER)}) found"
        )
    return index


def sequence_of(path: str) -> str:
    """The label sequence a recording's file stands for: its name before the first dot."""
    return Path(path).name.split(".")[0]


def segment_args(file: str, method: str, options: dict) -> argparse.Namespace:
    """The namespace ``streamseg segment FILE --method M --json`` would have parsed."""
    ns = dict(options)
    ns.update(file=file, method=method, json=True, plot=None, labels=None, sequence=None)
    ns["skeleton"] = skeleton_for(file, options.get("skeleton"))
    return argparse.Namespace(**ns)


def segment_object(file: str, method: str, options: dict) -> dict:
    """Exactly what ``streamseg segment --json`` prints for ``file`` (raises on failure)."""
    from streamseg.commands import METHODS

    module = importlib.import_module(METHODS[method])
    return module.segment(segment_args(file, method, options))


def score_object(obj: dict, labels_csv: str, sequence: str) -> dict:
    """The ``eval --all`` row of a ``segment --json`` object against human labels.

    Cuts and labels (lof, aca) get :func:`streamseg.evaluation.score`'s P/R/F1, covering and
    Hungarian frame accuracy; repetitions the scores of ``eval --method rep``
    (:func:`streamseg.commands.rep.set_scores`: per labelled set, repetitions matched by
    overlap).
    """
    from types import SimpleNamespace

    import numpy as np

    from streamseg.evaluation.corpus import LabelledRecording, Prediction, json_row, score
    from streamseg.evaluation.labels import read_labels

    truth = read_labels(labels_csv, sequence)
    n, fps = int(obj["n_frames"]), float(obj["fps"])
    if "repetitions" in obj:
        from streamseg.commands.rep import set_scores

        found = [[(r["start"], r["end"]) for r in st["repetitions"]] for st in obj["sets"]]
        return set_scores(found, truth, obj["count"])
    segments = obj.get("segments") or []
    labels = None
    if segments and all(s.get("label") is not None for s in segments):
        labels = np.full(n, -1, dtype=np.int64)
        for s in segments:
            labels[s["start"] : s["end"]] = int(s["label"])
    pred = Prediction(
        cuts=list(obj["cuts"]),
        labels=labels,
        latencies=obj.get("cut_latency_frames"),
        seconds=float(obj.get("seconds", float("nan"))),
    )
    item = LabelledRecording(sequence, SimpleNamespace(n_frames=n), truth)
    return json_row(score(item, pred, fps))


def run_one(file: str, method: str, options: dict, labels_csv: str | None = None) -> dict:
    """One JSON line of ``streamseg batch``: the segment object plus ``"file"`` (and
    ``"scores"`` against ``labels_csv``, ``"warnings"`` the method printed, ``"seconds"``
    when the method gives none), or ``{"file", "error"}``. Never raises."""
    t0 = time.perf_counter()
    said = io.StringIO()
    try:
        with contextlib.redirect_stderr(said):
            obj = segment_object(file, method, options)
            out = {"file": file, **obj}
            if labels_csv:
                out["scores"] = score_object(obj, labels_csv, sequence_of(file))
    except Exception as err:  # a bad recording is reported on its own line, the rest go on
        line = {"file": file, "error": _describe(err)}
        if cannot_be_read(err):
            line["skipped"] = True
        return line
    out.setdefault("seconds", round(time.perf_counter() - t0, 3))
    warnings = [w.strip() for w in said.getvalue().splitlines() if w.strip()]
    if warnings and "warnings" not in out:  # (the segment object keeps its own list)
        out["warnings"] = warnings
    # strict JSON now, in the task: a non-finite number becomes null before it travels
    return strict_json.finite(out)


def cannot_be_read(err: BaseException) -> bool:
    """Whether ``err`` says the input cannot be segmented as asked (a file that is not a
    recording, an AMC without its skeleton, markers no set maps, ...): the batch skips such a
    file with its reason, unlike a failure while running (an internal error, a lost task)."""
    from streamseg.exceptions import ParameterError, RecordingError, SkeletonError

    return isinstance(
        err,
        (
            ParameterError,
            RecordingError,
            SkeletonError,
            FileNotFoundError,
            IsADirectoryError,
            PermissionError,
            UnicodeDecodeError,
        ),
    )


def _describe(err: BaseException) -> str:
    from streamseg.exceptions import StreamsegError

    if isinstance(err, StreamsegError):
        return str(err)
    if isinstance(err, FileNotFoundError):
        return f"no such file: {err.filename}"
    return f"{type(err).__name__}: {err}"


def read_done(output) -> dict:
    """``{absolute path: line object}`` of an existing output file (the last line of a file
    wins; an unreadable line, e.g. cut short by a crash, is ignored)."""
    import json

    done = {}
    if not os.path.exists(output):
        return done
    with open(output, encoding="utf-8") as fh:
        for line in fh:
            try:
                obj = json.loads(line)
            except ValueError:
                continue
            if isinstance(obj, dict) and isinstance(obj.get("file"), str):
                done[os.path.abspath(obj["file"])] = obj
    return done


def summary(objects: list[dict]) -> str:
    """A markdown table, one row per recording: frames, result, seconds, or its error."""
    lines = ["| file | method | frames | result | seconds |", "|---|---|---|---|---|"]
    for o in objects:
        name = o["file"]
        if "error" in o:
            what = "skipped" if o.get("skipped") else "failed"
            lines.append(f"| {name} | | | {what}: {o['error'][:120]} | |")
            continue
        if "count" in o:
            result = f"{o['count']} repetitions"
        else:
            result = f"{len(o.get('cuts', []))} cuts"
            if o.get("n_clusters") is not None:
                result += f", {o['n_clusters']} actions"
        sec = o.get("seconds")
        lines.append(
            f"| {name} | {o.get('method', '')} | {o.get('n_frames', '')} | {result} "
            f"| {'' if sec is None else f'{sec:.2f}'} |"
        )
    return "\n".join(lines)


def write_line(fh, obj: dict) -> None:
    """Append one strict-JSON line, flushed: a crash of this process loses no finished
    recording (the caller syncs the file to disk at the end, not per line: on small
    recordings a sync per line cost more than the segmenting)."""
    fh.write(strict_json.dumps(obj) + "\n")
    fh.flush()
