"""Segment or evaluate a whole corpus on a Dask cluster (one JSON line per recording).

``streamseg batch PATH... --method lof|aca|rep --output FILE.jsonl`` runs ``segment`` with
the same options on every recording (files, globs, folders), on a local cluster (one worker
process per core, 127.0.0.1) or on ``--scheduler tcp://HOST:8786``. Each line is the
``segment --json`` object plus ``"file"``, or ``{"file", "error"}``, each with
``"batch_options"`` (the method and options it was made with);
a rerun skips recordings already in FILE (and refuses to mix results of other options;
``--retry-failed`` replaces their error lines; an error line made with other options, e.g.
before a ``--skeleton`` was given, runs again by itself). ``--labels`` scores each against
human labels as ``eval --all`` does. A recording that cannot be read as asked (not a
recording, an AMC without a skeleton, markers no set maps) is skipped: its line has the
reason and ``"skipped": true``. Exit code 0 when something was segmented and nothing failed
while running, else 1. Needs ``pip install streamseg[dask]``.
"""

from __future__ import annotations

import importlib
import os
import sys
import time

from streamseg.commands import METHODS
from streamseg.exceptions import ParameterError

# options of the batch itself; every other parsed option is a `segment` option for the task
_OWN = {
    "inputs",
    "output",
    "scheduler",
    "workers",
    "labels",
    "retry_failed",
    "method",
    "command",
    "run",
    "log_level",
    "method_options",
}


def add_arguments(parser) -> None:
    parser.add_argument(
        "inputs",
        nargs="+",
        metavar="PATH",
        help="recordings (.amc[.gz], .bvh, .npz, .npy, .csv), globs or folders "
        "(every recording under them)",
    )
    parser.add_argument(
        "--output",
        "-o",
        required=True,
        metavar="FILE.jsonl",
        help="one JSON line per recording, appended; a rerun skips the recordings already in it",
    )
    parser.add_argument("--method", choices=sorted(METHODS), default="lof")
    parser.add_argument(
        "--skeleton",
        help="ASF for AMCs whose folder has none (each AMC "
        "takes the ASF beside it whose name starts the file's name, or the "
        "only one there)",
    )
    from streamseg.commands.args import frame_rate

    parser.add_argument(
        "--fps",
        type=frame_rate,
        default=None,
        help="frame rate for feature matrices (.npy/.csv) or AMCs",
    )
    from streamseg.commands.inputs import add_source_arguments

    add_source_arguments(parser)
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: a "
        "local cluster on 127.0.0.1)",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="local cluster: worker processes (default: one per core)",
    )
    parser.add_argument(
        "--labels",
        metavar="CSV|DIR",
        help="score against human labels (a label CSV, or a folder searched "
        "for them; sequence = file name before the first dot)",
    )
    parser.add_argument(
        "--retry-failed",
        action="store_true",
        help="run again the recordings whose line in FILE is an error",
    )
    owned = {}  # method -> the option names of its group: what its results depend on
    for name in sorted(METHODS):
        module = importlib.import_module(METHODS[name])
        group = parser.add_argument_group(f"{name} options (as for segment)")
        module.add_arguments(group)
        owned[name] = [a.dest for a in group._group_actions]
    parser.set_defaults(method_options=owned)


def _options(args) -> dict:
    return {k: v for k, v in vars(args).items() if k not in _OWN}


def batch_key(args) -> dict:
    """What a line's result depends on: the method and its options, the skeleton and fps.
    Stored in every line (``"batch_options"``) so a rerun knows what it would mix."""
    dests = [*args.method_options.get(args.method, ()), "skeleton", "fps"]
    return {"method": args.method, **{d: getattr(args, d, None) for d in dests}}


def _refuse_mixing(done: dict, files, key: dict, output) -> None:
    """A rerun into a file whose lines for these recordings were made with other options
    would skip them and report the old results as if they were the new ones: refuse."""
    for f in files:
        line = done.get(os.path.abspath(f))
        if line is None or "error" in line:  # nothing to mix: an error line runs again
            continue
        theirs = line.get("batch_options")
        if theirs is None:  # a line of an older batch: only its method is known
            method = line.get("method")
            if (
                "error" in line
                or method is None
                or method.startswith(key["method"])
                or (key["method"] == "aca" and method == "haca")
            ):
                continue
            theirs = {"method": method}
        diff = [
            k
            for k in sorted(set(theirs) | set(key))
            if theirs.get(k) != key.get(k)
            and k in theirs
            and (k != "skeleton" or _needs_given_skeleton(f))
        ]
        if diff:

            def show(v):
                return "default" if v is None else repr(v)

            said = ", ".join(
                f"--{k.replace('_', '-')} {show(theirs.get(k))} (now {show(key.get(k))})"
                for k in diff[:3]
            )
            raise ParameterError(
                f"--output {output} already holds {os.path.basename(f)} made with other "
                f"options: {said}; a rerun would skip it and report the old result. Write to "
                "another --output file, or give the same options to resume that batch"
            )


def _needs_given_skeleton(path) -> bool:
    """Whether ``--skeleton`` decides how ``path`` is read: an AMC with no ASF of its own."""
    from streamseg.commands import batch_tasks as batch

    return ".amc" in os.path.basename(path).lower() and batch.skeleton_for(path) is None


def _compact(output, files) -> None:
    """Rewrite ``output`` with one line per recording (the newest), so a retried recording
    does not keep its old error line; lines of other recordings stay, in their order."""
    from streamseg.commands import batch_tasks as batch

    done = batch.read_done(output)
    order = list(dict.fromkeys([*done, *(os.path.abspath(f) for f in files)]))
    tmp = f"{output}.tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        for path in order:
            if path in done:
                batch.write_line(fh, done[path])
        os.fsync(fh.fileno())
    os.replace(tmp, output)


def run(args) -> int:
    from streamseg.commands import batch_tasks as batch
    from streamseg.evaluation.corpus import Progress
    from streamseg.scaleout import connect, local_cluster, require_distributed

    distributed = require_distributed()
    if args.workers is not None and args.workers < 1:
        raise ParameterError(f"--workers={args.workers}: expected an integer >= 1")
    out_dir = os.path.dirname(os.path.abspath(args.output))
    if not os.path.isdir(out_dir) or os.path.isdir(args.output):
        raise ParameterError(f"--output {args.output}: not a file in an existing folder")
    files = batch.expand(args.inputs)
    if not files:
        raise ParameterError(f"no recordings in {' '.join(args.inputs)}")
    labels = batch.label_index(args.labels) if args.labels else {}
    done = batch.read_done(args.output)
    key = batch_key(args)
    _refuse_mixing(done, files, key, args.output)
    todo = [f for f in files if _to_run(done.get(os.path.abspath(f)), key, args.retry_failed)]
    rerun = any(os.path.abspath(f) in done for f in todo)
    options = _options(args)
    cluster = client = None
    t0 = time.perf_counter()
    try:
        if todo:
            if args.scheduler:
                client = connect(args.scheduler)
                where = args.scheduler
            else:
                cluster = local_cluster(args.workers)
                client = distributed.Client(cluster, set_as_default=False)
                n = len(cluster.workers)
                where = f"a local cluster of {n} worker process{'es' if n != 1 else ''}"
            print(
                f"streamseg batch: {len(files)} recording{'s' if len(files) != 1 else ''}, "
                f"{len(files) - len(todo)} already "
                f"in {args.output}, {len(todo)} to run on {where}",
                file=sys.stderr,
            )
            futures = {}
            for i, f in enumerate(todo):
                fut = client.submit(
                    batch.run_one,
                    f,
                    args.method,
                    options,
                    labels.get(batch.sequence_of(f)),
                    pure=False,
                    key=f"batch-{i}-{os.path.basename(f)}",
                )
                futures[fut] = f
            bar = Progress(len(todo))
            with open(args.output, "a", encoding="utf-8") as fh:
                if fh.tell() and not _ends_with_newline(args.output):
                    fh.write("\n")  # a line cut short by a crash stays on its own
                for fut in distributed.as_completed(list(futures), loop=client.loop):
                    f = futures[fut]
                    try:
                        obj = fut.result()
                    except Exception as err:  # the task's worker died (again) or was lost
                        obj = {
                            "file": f,
                            "error": f"the cluster lost this task ({type(err).__name__}: {err})"[
                                :300
                            ],
                        }
                    fut.release()
                    obj["batch_options"] = key
                    batch.write_line(fh, obj)
                    done[os.path.abspath(f)] = obj
                    said = (
                        ""
                        if "error" not in obj
                        else "SKIPPED "
                        if obj.get("skipped")
                        else "FAILED "
                    )
                    bar.step(said + os.path.basename(f))
                os.fsync(fh.fileno())
            if rerun:  # retried recordings: their new line replaces the old one
                _compact(args.output, files)
        else:
            print(
                f"streamseg batch: all {len(files)} recordings are already in {args.output}",
                file=sys.stderr,
            )
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    objects = [done[os.path.abspath(f)] for f in files]
    _print_summary(objects, args, time.perf_counter() - t0, len(todo))
    # what cannot be read is skipped with its reason; a failure while running is a failure
    failed = any("error" in o and not o.get("skipped") for o in objects)
    return 1 if failed or all("error" in o for o in objects) else 0


def _to_run(line, key: dict, retry_failed: bool) -> bool:
    """Whether a recording runs: not in the output yet; or its line is an error and either
    ``--retry-failed`` asks for it or it was made with other options (a ``--skeleton``
    given since may be what it lacked)."""
    if line is None:
        return True
    if "error" not in line:
        return False
    return retry_failed or line.get("batch_options") != key


def _ends_with_newline(path) -> bool:
    with open(path, "rb") as fh:
        fh.seek(-1, os.SEEK_END)
        return fh.read(1) == b"\n"


def _print_summary(objects, args, wall: float, ran: int) -> None:
    from streamseg.commands import batch_tasks as batch
    from streamseg.evaluation.corpus import format_table, table_row

    print(batch.summary(objects))
    # strict JSON stored NaN (no accuracy for a method without labels...) as null
    scored = [
        (
            batch.sequence_of(o["file"]),
            o.get("method", args.method),
            table_row({k: float("nan") if v is None else v for k, v in o["scores"].items()}),
        )
        for o in objects
        if "scores" in o
    ]
    if scored and "F1" in scored[0][2]:
        print()
        print(format_table(scored))
    elif scored:
        print()
        print("| recording | alpha | count | true count | count error |")
        print("|---|---|---|---|---|")
        for name, _, s in scored:
            print(
                f"| {name} | {s['alpha']:.3f} | {s['count']} | {s['true_count']} | "
                f"{s['count_error']:.3f} |"
            )
    skipped = sum(1 for o in objects if o.get("skipped"))
    failed = sum(1 for o in objects if "error" in o and not o.get("skipped"))
    segmented = len(objects) - skipped - failed
    parts = [
        f"{len(objects)} recording{'s' if len(objects) != 1 else ''} ({ran} run now, "
        f"{len(objects) - ran} already in {args.output}): {segmented} segmented",
        f"{skipped} skipped (cannot be read as asked: the reason is in its line)",
        f"{failed} failed",
    ]
    if args.labels:
        parts.append(
            f"{len(scored)} scored against {args.labels} (the others have no rows in "
            "its label CSVs)"
        )
    print(f"\n{'; '.join(parts)}; {wall:.1f} s; lines in {args.output}")
