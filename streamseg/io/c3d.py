"""C3D files (Vicon, Qualisys, Motion Analysis, OptiTrack ...): marker trajectories in,
segmentation events out. Needs ``ezc3d`` (``pip install 'streamseg[c3d]'``).

Reading: the markers are mapped to the points the features need by the marker set that
covers them best (:mod:`streamseg.skeleton.marker_sets`); a C3D of a skeleton's joints (what
inertial suits and solvers export) is read by its joint names instead
(:func:`streamseg.io.positions.points_recording`); a file neither names is refused with the
markers each point lacks. Missing samples (a negative residual, or a marker at
exactly the origin) are NaN, and :func:`streamseg.io.read` fills short gaps as for any
recording. The up axis is the one the body stands along in the file (C3D has no standard
for it; ``POINT:Y_SCREEN`` when the body does not say).

Writing: :func:`write_events` copies a C3D file and adds the segmentation as C3D events
(``EVENT`` group: label, context, time in seconds from the start of the capture), which
Vicon Nexus and Mokka show on their timelines.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from streamseg.exceptions import ParameterError, RecordingError, TruncatedRecordingError
from streamseg.recording import Recording


def _ezc3d():
    try:
        import ezc3d
    except ImportError:
        raise ParameterError("reading C3D needs ezc3d: pip install 'streamseg[c3d]'") from None
    return ezc3d


def _open(path: Path):
    ezc3d = _ezc3d()
    try:
        return ezc3d.c3d(str(path)), None
    except (OSError, RuntimeError, ValueError) as err:
        first = str(err).splitlines()[0] if str(err) else type(err).__name__
    try:  # a file cut off: ezc3d reads what is there when told to ignore the format
        return ezc3d.c3d(str(path), ignore_bad_formatting=True), first
    except (OSError, RuntimeError, ValueError):
        raise RecordingError(
            path,
            None,
            f"an unreadable C3D file ({first})",
            "a C3D file (a binary file a mocap system exported)",
        ) from None


def _param(c, group: str, name: str, default=None):
    try:
        return c["parameters"][group][name]["value"]
    except KeyError:
        return default


def c3d_info(c) -> dict:
    """Rate, labels, first frame and manufacturer of an opened C3D (``ezc3d.c3d``)."""
    header = c["header"]["points"]
    labels = [str(x).strip() for x in _param(c, "POINT", "LABELS", [])]
    labels += [str(x).strip() for x in _param(c, "POINT", "LABELS2", [])]
    units = _param(c, "POINT", "UNITS", ["mm"])
    company = _param(c, "MANUFACTURER", "COMPANY", [""])
    return {
        "rate": float(header["frame_rate"]),
        "labels": labels,
        "first_frame": int(header["first_frame"]),
        "last_frame": int(header["last_frame"]),
        "units": str(units[0]).strip() if len(units) else "mm",
        "manufacturer": str(company[0]).strip() if len(company) else "",
    }


def read_c3d(
    path, skeleton=None, *, lenient: bool = False, fps: float | None = None, markers=None
) -> Recording:
    """Read a C3D file's markers as the canonical joints of the set that covers them.

    Parameters
    ----------
    path : str or Path
    skeleton : unused
    lenient : bool
        Keep the frames of a file cut off before its last frame (with a warning).
    fps : float, optional
        Replace the file's point rate.
    markers : str or Path or MarkerSet, optional
        A marker map of the user's own (``--markers MAP.toml``,
        :mod:`streamseg.skeleton.marker_map`) instead of the built-in marker sets.

    Returns
    -------
    Recording
        Joints :data:`streamseg.skeleton.marker_sets.JOINTS` and ``metadata["marker_set"]``
        for markers, the file's own joints for a skeleton's; ``metadata`` has
        ``manufacturer``, ``first_frame`` (the capture's frame number of frame 0), ``markers``
        (the labels) and ``warnings``.

    Raises
    ------
    RecordingError
        Unreadable file; neither a marker set nor a skeleton names the labels (naming the
        missing markers).
    """
    from streamseg.io.positions import points_recording

    path = Path(path)
    c, problem = _open(path)
    info = c3d_info(c)
    points = np.asarray(c["data"]["points"], dtype=np.float64)  # (4, n_markers, n_frames)
    n_said, held = _frames_in_file(path)
    n_said = max(n_said, points.shape[2])
    held = points.shape[2] if held < 0 else held
    warnings = []
    if problem is not None or held < n_said:
        kept = points.shape[2]
        if not lenient or kept == 0:
            raise TruncatedRecordingError(
                path,
                None,
                f"{kept} readable frames of the {n_said} "
                f"the file announces ({problem or 'cut off'})",
                "a complete C3D file",
            )
        warnings.append(
            f"{path.name}: the file was cut off: {kept} frames of the {n_said} "
            f"the file announces kept ({n_said - kept} dropped)"
        )
    labels = info["labels"][: points.shape[1]]
    if not labels:
        raise RecordingError(
            path,
            None,
            "no marker trajectories (POINT:LABELS is empty)",
            "a C3D file with labelled markers",
        )
    xyz = np.transpose(points[:3], (2, 1, 0)).copy()  # (n_frames, n_markers, 3)
    meta = c["data"].get("meta_points", {})
    resid = meta.get("residuals")
    if resid is not None and np.shape(resid)[-1] == xyz.shape[0]:
        xyz[np.transpose(np.asarray(resid)[0]) < 0] = np.nan
    xyz[(xyz == 0).all(axis=2)] = np.nan  # exporters write a lost marker as (0, 0, 0)
    rate = float(fps or info["rate"])
    if not rate > 0:
        raise RecordingError(path, None, f"point rate {info['rate']}", "a rate > 0, or --fps")
    meta = {
        "format": "c3d",
        "manufacturer": info["manufacturer"],
        "first_frame": info["first_frame"],
        "markers": labels,
        "warnings": warnings,
    }
    return points_recording(
        path,
        xyz,
        labels,
        rate,
        info["units"],
        meta,
        up=_screen_up(c),
        noun="markers",
        marker_map=markers,
    )


def _frames_in_file(path: Path) -> tuple[int, int]:
    """``(announced, held)``: the frames the file says it has and the frames its bytes hold.

    C3D says its length three ways: the header's first and last frame (16-bit words),
    ``POINT:FRAMES`` and, past 65535 frames, ``TRIAL:ACTUAL_START/END_FIELD`` (Vicon).
    Exporters disagree (an Optotrak file's header says 1149 frames, its ``POINT:FRAMES``
    and its bytes 29), so the file is cut off only when its data section holds fewer frames
    than every count it gives; past 65535 frames the TRIAL count alone is said. Read from the
    file's own bytes: ezc3d rewrites its copy of the header and ``POINT:FRAMES`` to what a
    cut-off file holds. ``(0, -1)`` when the header cannot be read.
    """
    import struct

    try:
        with open(path, "rb") as fh:
            data = fh.read()
        head = data[:512]
        order = ">" if data[(head[0] - 1) * 512 + 3] == 86 else "<"  # 86: MIPS, big-endian
        n_points, n_analog, first, last = struct.unpack(order + "4H", head[2:10])
        start = struct.unpack(order + "H", head[16:18])[0]
        params = _raw_params(data, head[0], order)
    except (struct.error, IndexError, ValueError):
        return 0, -1
    counts = [last - first + 1]
    if params.get(("POINT", "FRAMES")):
        counts.append(int(params["POINT", "FRAMES"][0]) & 0xFFFF)
    s, e = params.get(("TRIAL", "ACTUAL_START_FIELD")), params.get(("TRIAL", "ACTUAL_END_FIELD"))
    if s is not None and e is not None and len(s) == 2 and len(e) == 2:
        # two 16-bit words each: low word first (C3D user guide)
        span = (
            (int(e[0]) & 0xFFFF | (int(e[1]) & 0xFFFF) << 16)
            - (int(s[0]) & 0xFFFF | (int(s[1]) & 0xFFFF) << 16)
            + 1
        )
        counts = [span] if span > 65535 else counts + [span]
    scale = params.get(("POINT", "SCALE"), [-1.0])[0]
    start = int(params.get(("POINT", "DATA_START"), [start])[0]) or start
    frame_bytes = (4 * n_points + n_analog) * (4 if scale < 0 else 2)
    held = max(len(data) - (start - 1) * 512, 0) // frame_bytes if frame_bytes and start else -1
    counts = [n for n in counts if n > 0]
    return (min(counts) if counts else 0), held


def _raw_params(data: bytes, block: int, order: str) -> dict:
    """The numeric parameters of a C3D parameter section: ``(GROUP, NAME) -> list``.

    Records (C3D user guide): name length (int8; 0 ends), id (int8: a group if negative, else
    the parameter's group), name, offset to the next record (int16); a parameter then has its
    type (-1 char, 1 byte, 2 int16, 4 float), its dimensions and its data.
    """
    import struct

    dec = data[(block - 1) * 512 + 3] == 85  # DEC floats: IEEE with the words swapped, x4
    pos, groups, found = (block - 1) * 512 + 4, {}, []
    while pos + 4 < len(data):
        length, ident = struct.unpack("bb", data[pos : pos + 2])
        if length == 0:
            break
        name = data[pos + 2 : pos + 2 + abs(length)].decode("latin-1").strip().upper()
        here = pos + 2 + abs(length)
        step = struct.unpack(order + "h", data[here : here + 2])[0]
        if ident < 0:
            groups[-ident] = name
        else:
            kind, ndim = struct.unpack("bb", data[here + 2 : here + 4])
            dims = data[here + 4 : here + 4 + ndim]
            count = int(np.prod(list(dims))) if ndim else 1
            raw = data[here + 4 + ndim : here + 4 + ndim + count * abs(kind)]
            if kind == 2:
                found.append((ident, name, list(struct.unpack(f"{order}{count}h", raw))))
            elif kind == 4:
                if dec:
                    raw = b"".join(
                        raw[i + 2 : i + 4] + raw[i : i + 2] for i in range(0, len(raw), 4)
                    )
                values = struct.unpack(f"{order}{count}f", raw)
                found.append((ident, name, [v / 4 if dec else v for v in values]))
        if step == 0:
            break
        pos = here + step
    return {(groups.get(g, ""), name): values for g, name, values in found}


def _screen_up(c) -> str:
    """``POINT:Y_SCREEN`` as an up axis, else z (for a body that does not stand along one)."""
    from streamseg.recording import UP_AXES

    screen = _param(c, "POINT", "Y_SCREEN", [""])
    screen = str(screen[0]).strip().lower().lstrip("+") if len(screen) else ""
    return screen if screen in UP_AXES else "z"


def write_events(
    source, out, segments, fps: float, *, method: str = "streamseg", context: str = "General"
) -> int:
    """Copy C3D ``source`` to ``out`` with one event per segment start.

    Parameters
    ----------
    source, out : str or Path
        The C3D file read, and the file to write (may be the same path).
    segments : sequence of dict or (start, end, label)
        The segmentation (frames of the recording, 0-based, end exclusive).
    fps : float
        Frame rate of the frames.
    method : str
        Named in each event's description.
    context : str
        The C3D event context (``General``, ``Left``, ``Right``).

    Returns
    -------
    int
        Events written: ``Cut`` at each cut of a cut detector (segments without a label),
        ``Action N`` at the start of each segment of label N, at ``(first_frame + start) /
        fps`` seconds: the capture's clock, as Nexus and Mokka count it.
    """
    source, out = Path(source), Path(out)
    c, problem = _open(source)
    if problem is not None:
        raise RecordingError(
            source,
            None,
            f"a damaged C3D file ({problem})",
            "a complete C3D file to copy the events into",
        )
    first = c3d_info(c)["first_frame"]
    table = _event_table(c)
    n = 0
    for i, seg in enumerate(segments):
        start, end, label = (
            (seg["start"], seg["end"], seg.get("label")) if isinstance(seg, dict) else seg
        )
        if label is None and i == 0:
            continue  # a cut detector's first segment starts at the take's start
        row = {
            "TIMES": (0.0, (first + int(start)) / float(fps)),
            "CONTEXTS": context,
            "LABELS": f"Action {label}" if label is not None else "Cut",
            "DESCRIPTIONS": f"streamseg {method}: segment {i}, frames {int(start)}-{int(end)}",
            "SUBJECTS": "",
            "ICON_IDS": 0,
            "GENERIC_FLAGS": 0,
        }
        for name, value in row.items():
            table[name].append(value)
        n += 1
    if table["TIMES"]:
        c.add_parameter("EVENT", "USED", len(table["TIMES"]))
        c.add_parameter("EVENT", "TIMES", np.asarray(table["TIMES"], dtype=np.float64).T)
        for name, values in table.items():
            if name != "TIMES":
                c.add_parameter("EVENT", name, values)
    try:
        c.write(str(out))
    except (OSError, RuntimeError) as err:
        raise RecordingError(
            out, None, f"a file that cannot be written ({err})", "a writable path for the C3D file"
        ) from None
    return n


#: the EVENT parameters of one event each, and the value an exporter that left one out means
_EVENT_FIELDS = {
    "CONTEXTS": "General",
    "LABELS": "",
    "DESCRIPTIONS": "",
    "SUBJECTS": "",
    "ICON_IDS": 0,
    "GENERIC_FLAGS": 0,
}


def _event_table(c) -> dict:
    """The file's events as lists, one entry per event: ``TIMES`` ``(minutes, seconds)`` and
    the :data:`_EVENT_FIELDS`, a field the exporter left out filled with its default
    (Qualisys writes LABELS and TIMES only; OptiTrack an EVENT group with USED = 0 alone)."""
    ev = c["parameters"].get("EVENT") or {}
    used = int(np.asarray(ev.get("USED", {}).get("value", [0])).ravel()[0]) if ev else 0
    times = np.asarray(
        ev.get("TIMES", {}).get("value", np.zeros((2, used))), dtype=np.float64
    ).reshape(2, -1)[:, :used]
    used = min(used, times.shape[1])
    table = {"TIMES": [(float(times[0, i]), float(times[1, i])) for i in range(used)]}
    for name, fill in _EVENT_FIELDS.items():
        values = list(ev.get(name, {}).get("value", []))[:used]
        values = [str(v).strip() if isinstance(fill, str) else int(v) for v in values]
        table[name] = values + [fill] * (used - len(values))
    return table


def read_events(path) -> list[dict]:
    """The events of a C3D file: ``label``, ``context``, ``time`` (s), ``description``."""
    c, _ = _open(Path(path))
    t = _event_table(c)
    return [
        {
            "label": t["LABELS"][i],
            "context": t["CONTEXTS"][i] or "General",
            "time": minutes * 60 + seconds,
            "description": t["DESCRIPTIONS"][i],
        }
        for i, (minutes, seconds) in enumerate(t["TIMES"])
    ]
