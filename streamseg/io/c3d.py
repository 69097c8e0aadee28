"""C3D files (Vicon, Qualisys, Motion Analysis, OptiTrack ...): marker trajectories in,
segmentation events out. Needs ``ezc3d`` (``pip install 'streamseg[c3d]'``).

Reading: the markers are mapped to the points the features need by the marker set that
covers them best (:mod:`streamseg.skeleton.marker_sets`); a file no set covers is refused
with the markers each point lacks. Missing samples (a negative residual, or a marker at
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
from streamseg.recording import Recording, Skeleton


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
        raise RecordingError(path, None, f"an unreadable C3D file ({first})",
                             "a C3D file (a binary file a mocap system exported)") from None


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
    return {"rate": float(header["frame_rate"]), "labels": labels,
            "first_frame": int(header["first_frame"]),
            "last_frame": int(header["last_frame"]),
            "units": str(units[0]).strip() if len(units) else "mm",
            "manufacturer": str(company[0]).strip() if len(company) else ""}


def read_c3d(path, skeleton=None, *, lenient: bool = False,
             fps: float | None = None) -> Recording:
    """Read a C3D file's markers as the canonical joints of the set that covers them.

    Parameters
    ----------
    path : str or Path
    skeleton : unused
    lenient : bool
        Keep the frames of a file cut off before its last frame (with a warning).
    fps : float, optional
        Replace the file's point rate.

    Returns
    -------
    Recording
        Joints :data:`streamseg.skeleton.marker_sets.JOINTS`; ``metadata`` has
        ``marker_set``, ``manufacturer``, ``first_frame`` (the capture's frame number of
        frame 0), ``markers`` (the labels) and ``warnings``.

    Raises
    ------
    RecordingError
        Unreadable file; no marker set covers the labels (naming the missing markers).
    """
    from streamseg.skeleton.marker_sets import JOINTS, PARENTS, best_set, joint_positions

    path = Path(path)
    c, problem = _open(path)
    info = c3d_info(c)
    points = np.asarray(c["data"]["points"], dtype=np.float64)  # (4, n_markers, n_frames)
    n_said = max(info["last_frame"] - info["first_frame"] + 1, _announced_frames(path, c))
    warnings = []
    if problem is not None or points.shape[2] < n_said:
        kept = points.shape[2]
        if not lenient or kept == 0:
            raise TruncatedRecordingError(path, None, f"{kept} readable frames of the {n_said} "
                                          f"the header announces ({problem or 'cut off'})",
                                          "a complete C3D file")
        warnings.append(f"{path.name}: the file was cut off: {kept} frames of the {n_said} "
                        f"the header announces kept ({n_said - kept} dropped)")
    labels = info["labels"][:points.shape[1]]
    if not labels:
        raise RecordingError(path, None, "no marker trajectories (POINT:LABELS is empty)",
                             "a C3D file with labelled markers")
    mset, chosen, missing = best_set(labels)
    if missing:
        lack = "; ".join(f"{p} ({' '.join(m)})" for p, m in missing.items())
        raise RecordingError(path, None, f"{len(labels)} markers ({', '.join(labels[:12])}"
                             f"{' ...' if len(labels) > 12 else ''})",
                             f"a marker set streamseg maps; closest: {mset.name} "
                             f"({mset.description}), which lacks, per joint: {lack}")
    xyz = np.transpose(points[:3], (2, 1, 0)).copy()  # (n_frames, n_markers, 3)
    meta = c["data"].get("meta_points", {})
    resid = meta.get("residuals")
    if resid is not None and np.shape(resid)[-1] == xyz.shape[0]:
        xyz[np.transpose(np.asarray(resid)[0]) < 0] = np.nan
    xyz[(xyz == 0).all(axis=2)] = np.nan  # exporters write a lost marker as (0, 0, 0)
    joints = joint_positions(xyz, labels, chosen)
    up = _up_axis(joints, c)
    n = len(JOINTS)
    skel = Skeleton(JOINTS, np.array(PARENTS), np.zeros((n, 3)), info["units"], up)
    rate = float(fps or info["rate"])
    if not rate > 0:
        raise RecordingError(path, None, f"point rate {info['rate']}", "a rate > 0, or --fps")
    return Recording(rate, skel, joints, None, str(path),
                     {"format": "c3d", "marker_set": mset.name,
                      "manufacturer": info["manufacturer"], "first_frame": info["first_frame"],
                      "markers": labels, "warnings": warnings})


def _announced_frames(path: Path, c) -> int:
    """Frames the exporter announced: the file's own header words (ezc3d shortens its copy of
    the header to what a cut-off file holds) or ``TRIAL:ACTUAL_START/END_FIELD`` (Vicon,
    also past 65535 frames). 0 when neither says."""
    import struct

    n = 0
    try:
        with open(path, "rb") as fh:
            head = fh.read(512)
            fh.seek(max(head[0] - 1, 0) * 512)
            param = fh.read(4)
        order = ">" if len(param) == 4 and param[3] == 86 else "<"  # 86: MIPS, big-endian
        first, last = struct.unpack(order + "HH", head[6:10])
        n = last - first + 1
    except (OSError, struct.error, IndexError):
        pass
    start = _param(c, "TRIAL", "ACTUAL_START_FIELD", None)
    end = _param(c, "TRIAL", "ACTUAL_END_FIELD", None)
    if start is not None and end is not None and len(start) == 2 and len(end) == 2:
        # two 16-bit words each: low word first (C3D user guide)
        s0 = int(start[0]) & 0xFFFF | (int(start[1]) & 0xFFFF) << 16
        e0 = int(end[0]) & 0xFFFF | (int(end[1]) & 0xFFFF) << 16
        n = max(n, e0 - s0 + 1)
    return n


def _up_axis(joints: np.ndarray, c) -> str:
    """The axis the body stands along, else ``POINT:Y_SCREEN``, else z."""
    from streamseg.recording import UP_AXES
    from streamseg.skeleton.bones import upright_axis
    from streamseg.skeleton.marker_sets import JOINTS

    axis = upright_axis(joints, JOINTS)
    if axis is not None:
        return axis
    screen = _param(c, "POINT", "Y_SCREEN", [""])
    screen = str(screen[0]).strip().lower().lstrip("+") if len(screen) else ""
    return screen if screen in UP_AXES else "z"


def write_events(source, out, segments, fps: float, *, method: str = "streamseg",
                 context: str = "General") -> int:
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
        raise RecordingError(source, None, f"a damaged C3D file ({problem})",
                             "a complete C3D file to copy the events into")
    first = c3d_info(c)["first_frame"]
    _complete_event_group(c)
    n = 0
    for i, seg in enumerate(segments):
        start, end, label = ((seg["start"], seg["end"], seg.get("label")) if isinstance(seg, dict)
                             else seg)
        if label is None and i == 0:
            continue  # a cut detector's first segment starts at the take's start
        name = f"Action {label}" if label is not None else "Cut"
        seconds = (first + int(start)) / float(fps)
        c.add_event(time=[0, seconds], context=context, label=name,
                    description=f"streamseg {method}: segment {i}, frames {int(start)}-"
                                f"{int(end)}")
        n += 1
    try:
        c.write(str(out))
    except (OSError, RuntimeError) as err:
        raise RecordingError(out, None, f"a file that cannot be written ({err})",
                             "a writable path for the C3D file") from None
    return n


def _complete_event_group(c) -> None:
    """Give an ``EVENT`` group the parameters some exporters leave out (Qualisys writes
    LABELS and TIMES only), so that events can be added to it."""
    ev = c["parameters"].get("EVENT")
    if not ev or "USED" not in ev:
        return
    used = int(np.asarray(ev["USED"]["value"]).ravel()[0])
    for name, fill in (("CONTEXTS", "General"), ("LABELS", ""), ("DESCRIPTIONS", ""),
                       ("SUBJECTS", ""), ("ICON_IDS", 0), ("GENERIC_FLAGS", 0)):
        if name not in ev:
            c.add_parameter("EVENT", name, [fill] * used)
    if "TIMES" not in ev:
        c.add_parameter("EVENT", "TIMES", np.zeros((2, used)))


def read_events(path) -> list[dict]:
    """The events of a C3D file: ``label``, ``context``, ``time`` (s), ``description``."""
    c, _ = _open(Path(path))
    ev = c["parameters"].get("EVENT", {})
    if not ev or not int(np.asarray(ev.get("USED", {}).get("value", [0])).ravel()[0]):
        return []
    times = np.asarray(ev["TIMES"]["value"], dtype=np.float64)

    def strings(name):
        values = ev.get(name, {}).get("value", [])
        return [str(x).strip() for x in values] + [""] * (times.shape[1] - len(values))

    labels, contexts, descr = strings("LABELS"), strings("CONTEXTS"), strings("DESCRIPTIONS")
    return [{"label": labels[i], "context": contexts[i] or "General",
             "time": float(times[0, i] * 60 + times[1, i]), "description": descr[i]}
            for i in range(times.shape[1])]
