"""The command line's output contract (``docs/output.md``): one shape for every method.

``segment`` returns :func:`segmentation` objects, ``eval`` :func:`evaluation` objects; both
print as strict JSON with ``--json`` and as a readable table otherwise. Warnings go to stderr
as one line each *and* into the object's ``warnings`` list, so a script reading the JSON sees
them too.
"""

from __future__ import annotations

import sys

#: Version of the JSON objects described in docs/output.md.
SCHEMA = 1


def warn(args, message: str) -> None:
    """Print ``message`` as one warning line and keep it for the JSON ``warnings`` list."""
    if not hasattr(args, "warnings"):
        args.warnings = []
    if message not in args.warnings:
        args.warnings.append(message)
        print(
            f"streamseg {getattr(args, 'command', '')}: warning: {message}".replace("  ", " "),
            file=sys.stderr,
        )


def check_label_extent(args, segs, sequence: str, n_frames: int) -> None:
    """A warning when the label segments ``segs`` of ``sequence`` reach past the recording's
    ``n_frames`` (they are clipped there; often a label file of another take)."""
    end = max((s.end for s in segs), default=0)
    if end > n_frames:
        warn(
            args,
            f"{args.labels}: the labels of {sequence} reach frame {end} (end_frame, "
            f"1-based), past the recording's {n_frames} frames: scored up to the end "
            "(check the label file and --sequence)",
        )


def merge_runs(segments) -> list[tuple[int, int, object]]:
    """Adjacent segments of one label merged: ACA tiles one action with several pieces."""
    out: list[list] = []
    for s, e, lab in segments:
        if out and lab is not None and out[-1][2] == lab and out[-1][1] == s:
            out[-1][1] = int(e)
        else:
            out.append([int(s), int(e), lab])
    return [tuple(x) for x in out]


def segmentation(args, *, method: str, n_frames: int, fps: float, segments, **extra) -> dict:
    """The ``segment`` object: frames and seconds of every cut and segment, same-label runs
    merged (``segments`` as (start, end, label) tiling the frames; label None for cut
    detectors, which do not say which segments are alike)."""
    merged = merge_runs(segments)
    segs = [
        {
            "start": s,
            "end": e,
            "label": lab,
            "start_s": round(s / fps, 4),
            "end_s": round(e / fps, 4),
        }
        for s, e, lab in merged
    ]
    cuts = [s["start"] for s in segs[1:]]
    out = {
        "schema": SCHEMA,
        "command": "segment",
        "file": str(args.file),
        "method": method,
        "n_frames": int(n_frames),
        "fps": float(fps),
        "duration_s": round(n_frames / fps, 4) if fps else None,
        "cuts": cuts,
        "cuts_s": [round(c / fps, 4) for c in cuts],
        "segments": segs,
    }
    out.update(extra)
    if getattr(args, "gaps", None) is not None:  # a recording (not a feature matrix)
        out["gaps"] = list(args.gaps)
        out["filled_frames"] = int(getattr(args, "filled_frames", 0))
    out["warnings"] = list(getattr(args, "warnings", []))
    return out


def evaluation(args, *, method: str, n_frames: int, fps: float, **scores) -> dict:
    """The ``eval`` object: the method's scores against ``args.labels``."""
    out = {
        "schema": SCHEMA,
        "command": "eval",
        "file": str(args.file),
        "labels": args.labels,
        "method": method,
        "n_frames": int(n_frames),
        "fps": float(fps),
    }
    out.update(scores)
    out["warnings"] = list(getattr(args, "warnings", []))
    return out


def _cell(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return "-" if v is None else str(v)


def format_segmentation(result: dict) -> str:
    """A readable table of a :func:`segmentation` object."""
    n, fps = result["n_frames"], result["fps"]
    segs = result["segments"]
    head = (
        f"{result['file']}: {result['method']}, {len(result['cuts'])} cuts, "
        f"{len(segs)} segments over {n} frames ({n / fps:.2f} s at {fps:g} fps)"
    )
    if result.get("method") == "rep":  # its sets: what a user of a counter reads first
        lines = [
            head,
            f"  {'set':>3} {'start s':>9} {'end s':>9} {'label':>5} {'count':>5}  "
            f"{'s per repetition':>16}  confidence",
        ]
        for i, st in enumerate(result.get("sets") or []):
            tempo = f"{st['tempo_min_s']:.2f}-{st['tempo_max_s']:.2f}"
            lines.append(
                f"  {i:>3} {st['start'] / fps:>9.2f} {st['end'] / fps:>9.2f} "
                f"{_cell(st['label']):>5} {st['count']:>5}  {tempo:>16}  "
                f"{st['confidence']:.2f}"
            )
    else:
        extra = ""
        # segment --online: the latency of the cut that starts each segment but the first
        lat = result.get("cut_latency_s")
        lat = lat if lat is not None and len(lat) == len(segs) - 1 else None
        first = result.get("cut_first_latency_s") if lat is not None else None
        if lat is not None:
            extra += "  decided after s" + ("  first shown after s" if first else "")
        lines = [
            head,
            f"  {'#':>3} {'start':>7} {'end':>7} {'start s':>9} {'end s':>9}  label{extra}",
        ]
        for i, s in enumerate(segs):
            label = _cell(s["label"])
            if lat is not None:
                label = f"{label:>5}  " + (f"{lat[i - 1]:>16.2f}" if i else f"{'':>16}")
                if first:
                    label += f"  {first[i - 1]:>20.2f}" if i else ""
            lines.append(
                f"  {i:>3} {s['start']:>7} {s['end']:>7} {s['start_s']:>9.2f} "
                f"{s['end_s']:>9.2f}  {label}".rstrip()
            )
    skip = {
        "schema",
        "command",
        "file",
        "method",
        "n_frames",
        "fps",
        "duration_s",
        "cuts",
        "cuts_s",
        "segments",
        "warnings",
        "params",
        "repetitions",
        "sets",
        "filled_frames",
    }
    for key, value in result.items():
        if key in skip or isinstance(value, (dict, list)):
            continue
        lines.append(f"  {key}: {_cell(value)}")
    return "\n".join(lines)


def _confusion_lines(matrix, clusters, names) -> list[str]:
    """The confusion matrix with its headers: a row per found cluster, a column per human
    action, frames in each cell."""
    clusters = clusters or list(range(len(matrix)))
    names = names or [str(j) for j in range(len(matrix[0]) if matrix else 0)]
    width = max([6, *(len(str(n)) for n in names)])
    lines = [
        "  confusion (frames; rows: found clusters, columns: human actions):",
        "    " + f"{'cluster':>8} " + " ".join(f"{n:>{width}}" for n in names),
    ]
    lines += [
        "    " + f"{c:>8} " + " ".join(f"{v:>{width}d}" for v in row)
        for c, row in zip(clusters, matrix, strict=True)
    ]
    return lines


def format_evaluation(result: dict) -> str:
    """A readable list of an :func:`evaluation` object's scores."""
    lines = [f"{result['file']} against {result['labels']}: {result['method']}"]
    skip = {"schema", "command", "file", "labels", "method", "warnings"}
    for key, value in result.items():
        if key in skip:
            continue
        if key == "confusion":
            lines += _confusion_lines(value, result.get("clusters"), result.get("label_names"))
        elif key == "sets" and value and isinstance(value[0], dict):  # eval --rep-sets
            lines += [
                f"  {key}:",
                f"    {'start':>7} {'end':>7} {'true':>5} {'found':>5} {'alpha':>6}  label",
            ]
            lines += [
                f"    {st['start']:>7} {st['end']:>7} {st['true_count']:>5} "
                f"{st['count']:>5} {_cell(st['alpha']):>6}  {st['label']}"
                for st in value
            ]
        elif isinstance(value, list) and len(value) > 12:
            lines.append(f"  {key}: [{len(value)} items] {value[:12]} ...")
        else:
            shown = value if isinstance(value, (list, dict)) else _cell(value)
            lines.append(f"  {key}: {shown}")
    return "\n".join(lines)
