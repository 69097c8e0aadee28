"""``streamseg info`` on a file it can read but not segment as it stands: what the file holds
(frames, rate, markers or bones, events) and what segmenting it would need."""

from __future__ import annotations

from pathlib import Path

from streamseg.io._text import base_suffix


def describe(path, problem: Exception) -> str | None:
    """The description of ``path`` when its reader refused it for ``problem`` (markers no
    set maps, an AMC without its skeleton), or None when the file cannot be read at all."""
    suffix = base_suffix(path)
    try:
        if suffix == ".c3d":
            lines = _c3d(path)
        elif suffix == ".trc":
            lines = _trc(path)
        elif suffix == ".amc":
            lines = _amc(path)
        else:
            return None
    except Exception:  # unreadable after all: the reader's own error says why
        return None
    if lines is None:
        return None
    need = str(problem).split(": ", 1)[-1]
    lines.append(f"segmenting: not as it stands: {need}")
    if suffix in (".c3d", ".trc"):
        from streamseg.skeleton.marker_map import template

        markers = lines.pop(0)  # (the label list, kept out of the printed lines above)
        lines.append(
            "a marker map for --markers MAP.toml (fill in the markers of each "
            "joint; docs/guide/formats.md, Marker maps):"
        )
        lines += ["  " + t for t in template(markers).splitlines()]
    return "\n".join(lines)


def _c3d(path) -> list:
    from streamseg.io.c3d import _open, c3d_info, read_events

    c, _ = _open(Path(path))
    info = c3d_info(c)
    n = int(c["data"]["points"].shape[2])
    labels = info["labels"][: int(c["data"]["points"].shape[1])]
    events = read_events(path)
    out = [
        labels,
        f"file:      {path}",
        "format:    c3d" + (f" ({info['manufacturer']})" if info["manufacturer"] else ""),
        f"frames:    {n}",
        f"fps:       {info['rate']:g}",
        f"duration:  {n / info['rate']:.2f} s" if info["rate"] > 0 else "duration:  ?",
        f"units:     {info['units']}",
        f"markers:   {len(labels)} ({', '.join(labels)})",
    ]
    shown = ", ".join(f"{e['label']} ({e['context']}) {e['time']:.3f} s" for e in events[:20])
    out.append(
        f"events:    {len(events)}"
        + (f" ({shown}{' ...' if len(events) > 20 else ''})" if events else "")
    )
    return out


def _trc(path) -> list | None:
    lines = Path(path).read_text(encoding="utf-8", errors="replace").splitlines()
    if len(lines) < 5 or not lines[0].startswith("PathFileType"):
        return None
    keys = dict(zip(lines[1].split("\t"), lines[2].split("\t"), strict=False))
    head = lines[3].split("\t")
    names = [head[c].strip() for c in range(2, len(head), 3) if head[c].strip()]
    rows = sum(1 for line in lines[5:] if line.strip())
    rate = keys.get("DataRate", "?").strip()
    return [
        names,
        f"file:      {path}",
        "format:    trc",
        f"frames:    {rows}",
        f"fps:       {rate}",
        f"units:     {keys.get('Units', '?').strip()}",
        f"markers:   {len(names)} ({', '.join(names)})",
    ]


def _amc(path) -> list:
    from streamseg.io._text import read_text

    frames, bones = 0, []
    for line in read_text(path).split("\n"):
        word = line.split(maxsplit=1)[0] if line.strip() else ""
        if word.isdigit():
            frames += 1
        elif frames == 1 and word and not word.startswith(("#", ":")):
            bones.append(word)
    return [
        f"file:      {path}",
        "format:    amc (joint angles; the bones' lengths and axes are in the subject's ASF)",
        f"frames:    {frames}",
        "fps:       not stored in an AMC (120 for CMU and HDM05; --fps replaces it)",
        f"bones:     {len(bones)} ({', '.join(bones)})",
    ]
