"""Acclaim skeleton files (ASF), as CMU and HDM05 write them."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from streamseg.exceptions import RecordingError
from streamseg.io._text import read_text

INCH_M = 0.0254  # Acclaim lengths are inches divided by the `:units length` scale


@dataclass(frozen=True)
class Bone:
    """One ASF bone.

    Attributes
    ----------
    name : str
    direction : ndarray, shape (3,)
        Unit direction from the bone's start to its end in the rest pose, world axes.
    length : float
        Bone length in metres (the file's value divided by the length scale, in inches).
    axis : ndarray, shape (3,)
        Euler angles (radians) of the bone's local frame.
    axis_order : str
        Order of ``axis`` (e.g. ``"xyz"``), first letter applied first.
    dof : tuple of str
        Channels in AMC order, e.g. ``("rx", "ry", "rz")``; translations ``tx`` etc. for root.
    """

    name: str
    direction: np.ndarray
    length: float
    axis: np.ndarray
    axis_order: str
    dof: tuple


@dataclass(frozen=True)
class AcclaimSkeleton:
    """A parsed ASF: bones in parent-before-child order, root first (``bones[0].name == "root"``).

    Attributes
    ----------
    bones : tuple of Bone
    parents : tuple of int
        Parent index per bone, -1 for the root.
    angle_unit : {"deg", "rad"}
    length_scale : float
        ``:units length`` of the file.
    path : str
    root_position : ndarray, shape (3,)
        ``:root position`` in metres, added to every frame's root translation.
    """

    bones: tuple
    parents: tuple
    angle_unit: str
    length_scale: float
    path: str
    root_position: np.ndarray

    @property
    def names(self) -> tuple:
        return tuple(b.name for b in self.bones)


def _floats(path, lineno, words, n, what):
    try:
        vals = [float(w) for w in words[:n]]
    except ValueError:
        vals = []
    if len(vals) != n:
        raise RecordingError(path, lineno, f"{' '.join(words)!r}", f"{n} numbers for {what}")
    return np.array(vals)


def read_asf(path) -> AcclaimSkeleton:
    """Parse an ASF file.

    Raises
    ------
    RecordingError
        With the file, line, what was found and what was expected.
    """
    path = Path(path)
    lines = read_text(path).split("\n")
    scale, angle_unit = 1.0, "deg"
    root_order, root_axis_order = ("tx", "ty", "tz", "rx", "ry", "rz"), "xyz"
    root_orientation, root_position = np.zeros(3), np.zeros(3)
    bones: dict[str, dict] = {}
    children: dict[str, list] = {}
    section, current = None, None
    for lineno, raw in enumerate(lines, start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        words = line.split()
        key = words[0].lower()
        if key.startswith(":"):
            section = key
            continue
        if section == ":units":
            if key == "length":
                scale = float(_floats(path, lineno, words[1:], 1, "the length scale")[0])
                if not (np.isfinite(scale) and scale > 0):
                    raise RecordingError(
                        path, lineno, f"length scale {scale}", "a length scale > 0"
                    )
            elif key == "angle":
                unit = words[1].lower() if len(words) > 1 else ""
                if unit not in ("deg", "rad"):
                    raise RecordingError(path, lineno, f"angle unit {unit!r}", "deg or rad")
                angle_unit = unit
        elif section == ":root":
            if key == "order":
                root_order = tuple(w.lower() for w in words[1:])
            elif key == "axis":
                root_axis_order = words[1].lower() if len(words) > 1 else "xyz"
            elif key == "position":
                root_position = _floats(path, lineno, words[1:], 3, "root position")
            elif key == "orientation":
                root_orientation = _floats(path, lineno, words[1:], 3, "root orientation")
        elif section == ":bonedata":
            if key == "begin":
                current = {"line": lineno, "dof": (), "axis": np.zeros(3), "axis_order": "xyz"}
            elif key == "end":
                if current is None or "name" not in current:
                    raise RecordingError(
                        path,
                        lineno,
                        "a bone block without a name",
                        "'name NAME' between begin and end",
                    )
                for field in ("direction", "length"):
                    if field not in current:
                        raise RecordingError(
                            path,
                            current["line"],
                            f"bone {current['name']!r} without {field}",
                            f"a '{field}' line in every bone block",
                        )
                bones[current["name"]] = current
                current = None
            elif current is None:
                raise RecordingError(path, lineno, f"{line!r} outside a bone block", "begin")
            elif key == "name":
                if len(words) < 2:
                    raise RecordingError(path, lineno, "'name' without a value", "name BONE")
                current["name"] = words[1]
            elif key == "direction":
                current["direction"] = _floats(path, lineno, words[1:], 3, "direction")
            elif key == "length":
                current["length"] = float(_floats(path, lineno, words[1:], 1, "length")[0])
            elif key == "axis":
                current["axis"] = _floats(path, lineno, words[1:], 3, "axis")
                current["axis_order"] = words[4].lower() if len(words) > 4 else "xyz"
            elif key == "dof":
                dof = tuple(w.lower() for w in words[1:])
                bad = [d for d in dof if d not in ("rx", "ry", "rz", "tx", "ty", "tz", "l")]
                if bad:
                    raise RecordingError(
                        path, lineno, f"dof {bad[0]!r}", "rx, ry, rz, tx, ty, tz or l"
                    )
                current["dof"] = dof
        elif section == ":hierarchy":
            if key in ("begin", "end"):
                continue
            children.setdefault(words[0], []).extend(words[1:])
    if not bones:
        raise RecordingError(path, None, "no :bonedata section with bones", "an ASF skeleton")
    if "root" not in children:
        raise RecordingError(
            path,
            None,
            "no hierarchy line starting with root",
            "a :hierarchy section rooted at 'root'",
        )
    to_rad = np.pi / 180.0 if angle_unit == "deg" else 1.0
    ordered = [
        Bone(
            "root",
            np.zeros(3),
            0.0,
            root_orientation * to_rad,
            "".join(a[-1] for a in root_axis_order),
            root_order,
        )
    ]
    parents = [-1]
    queue = [("root", 0)]
    placed = {"root"}
    while queue:
        name, idx = queue.pop(0)
        for child in children.get(name, []):
            if child in placed:
                raise RecordingError(
                    path,
                    None,
                    f"bone {child!r} reached twice in :hierarchy "
                    "(a cycle or a bone with two parents)",
                    "a tree rooted at 'root'",
                )
            placed.add(child)
            if child not in bones:
                raise RecordingError(
                    path,
                    None,
                    f"hierarchy names unknown bone {child!r}",
                    f"one of the defined bones: {', '.join(sorted(bones))}",
                )
            b = bones[child]
            d = b["direction"]
            norm = np.linalg.norm(d)
            ordered.append(
                Bone(
                    child,
                    d / norm if norm > 0 else d,
                    b["length"] / scale * INCH_M,
                    b["axis"] * to_rad,
                    b["axis_order"],
                    b["dof"],
                )
            )
            parents.append(idx)
            queue.append((child, len(ordered) - 1))
    return AcclaimSkeleton(
        tuple(ordered), tuple(parents), angle_unit, scale, str(path), root_position / scale * INCH_M
    )
