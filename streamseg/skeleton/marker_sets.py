"""Optical marker sets mapped to the canonical points the features need.

Each set says, for every canonical point of :data:`streamseg.skeleton.names.POINTS`, how to
get it from markers: a joint centre where the set has the markers that define one (the mean
of a lateral and a medial epicondyle or malleolus; the hip centres of a pelvis by Bell,
Pedersen & Brand 1990), otherwise a marker or the mean of a cluster on the segment, which
gives the limb's direction (all the bone-angle features use). Alternatives are tried in
order: the first whose markers are all present wins; frame by frame, where its markers are
lost, the next alternative seen there serves. Before that, a marker lost in some frames is
placed from its segment's other markers (:attr:`MarkerSet.clusters`,
:mod:`streamseg.skeleton.marker_fill`).

Sets:

* ``plug-in-gait``: Vicon Plug-in Gait full body (39 markers; the CMU database's 41-marker
  variant names the pelvis markers LFWT/RFWT/LBWT/RBWT instead of LASI/RASI/LPSI/RPSI);
* ``qualisys-isb``: Qualisys full-body sets named after ISB/Van Sint Jan landmarks (L_IAS,
  L_FLE, L_FME, L_FAL, L_TAM, L_HLE, L_HME, L_RSP, L_UHE, L_SAJ, CV7, SNJ, SXS, TV8 ...);
* ``qualisys-sports``: Qualisys Sports / running sets (LASIS, LBackAsis, LKneeLat,
  LAnkleLat, LElbowLat, LWristLat/LWristMed, LAcromium, C7, Sternum, T10 ...).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from streamseg.skeleton.names import bare

# recipe: tuple of alternatives; an alternative is a tuple of marker names (their mean), or
# ("@hip", side) for a Bell hip centre from the pelvis markers.
_PIG_PELVIS = (
    ("LASI", "RASI", "LPSI", "RPSI"),
    ("LASI", "RASI", "SACR"),
    ("LFWT", "RFWT", "LBWT", "RBWT"),
)


def _sides(left: dict) -> dict:
    """A recipe table with its right side made from its left (``L`` -> ``R`` prefixes)."""
    out = dict(left)
    for point, alts in left.items():
        if not point.startswith("l_"):
            continue
        out["r_" + point[2:]] = tuple(
            ("@hip", "r") if alt[0] == "@hip" else tuple(_swap(m) for m in alt) for alt in alts
        )
    return out


def _swap(marker: str) -> str:
    if marker.startswith("L_"):
        return "R_" + marker[2:]
    if marker.startswith("L"):
        return "R" + marker[1:]
    return marker


@dataclass(frozen=True)
class MarkerSet:
    """How one marker set reaches the canonical points.

    Attributes
    ----------
    name : str
    description : str
    points : dict
        Canonical point -> alternatives (each a tuple of marker names whose mean it is, or
        ``("@hip", "l"|"r")``).
    pelvis : tuple of tuple
        Alternatives for the pelvis markers of the hip centres: (LASIS, RASIS, posterior...).
    clusters : tuple of tuple of str
        Markers on one rigid segment (a lost one is placed from the others seen).
    pairs : tuple
        ``((left_a, right_a), (left_b, right_b))`` of a segment: a marker of one pair lost in
        every frame is its twin mirrored across the other pair's mid-plane.
    """

    name: str
    description: str
    points: dict
    pelvis: tuple = ()
    clusters: tuple = ()
    pairs: tuple = ()


def _both(*clusters) -> tuple:
    """Clusters given for the left side, with their right-side twins."""
    return tuple(clusters) + tuple(
        tuple(_swap(m) for m in c) for c in clusters if all(m.startswith("L") for m in c)
    )


PLUG_IN_GAIT = MarkerSet(
    "plug-in-gait",
    "Vicon Plug-in Gait full body (CMU variant: LFWT/RFWT/LBWT/RBWT)",
    _sides(
        {
            "pelvis": _PIG_PELVIS,
            "spine": (("T10", "STRN"), ("T10",), ("STRN",)),
            "sternum": (("CLAV", "STRN"), ("CLAV",), ("STRN",)),
            "neck": (("C7", "CLAV"), ("C7",), ("CLAV",)),
            "l_shoulder": (("LSHO",),),
            "l_elbow": (("LELB",),),
            "l_wrist": (("LWRA", "LWRB"), ("LWRA",), ("LWRB",)),
            "l_hip": (("@hip", "l"),),
            "l_knee": (("LKNE",), ("LTHI", "LTIB")),
            "l_ankle": (("LANK",), ("LHEE",)),
        }
    ),
    pelvis=(
        ("LASI", "RASI", "LPSI", "RPSI"),
        ("LASI", "RASI", "SACR"),
        ("LFWT", "RFWT", "LBWT", "RBWT"),
    ),
    clusters=_both(
        ("LASI", "RASI", "LPSI", "RPSI", "SACR"),
        ("LFWT", "RFWT", "LBWT", "RBWT"),
        ("C7", "T10", "CLAV", "STRN"),
        ("LFHD", "RFHD", "LBHD", "RBHD"),
        ("LSHO", "LUPA", "LELB"),
        ("LELB", "LFRM", "LWRA", "LWRB"),
        ("LWRA", "LWRB", "LFIN"),
        ("LKNE", "LTIB", "LANK"),
        ("LANK", "LHEE", "LTOE"),
    ),
    pairs=((("LASI", "RASI"), ("LPSI", "RPSI")), (("LFWT", "RFWT"), ("LBWT", "RBWT"))),
)

QUALISYS_ISB = MarkerSet(
    "qualisys-isb",
    "Qualisys full body with ISB landmark names (IAS, IPS, FLE/FME, FAL/TAM, HLE/HME, "
    "RSP/UHE, SAJ, CV7, SNJ, SXS, TV8)",
    _sides(
        {
            "pelvis": (("L_IAS", "R_IAS", "L_IPS", "R_IPS"),),
            "spine": (("TV8", "SXS"),),
            "sternum": (("SNJ", "SXS"),),
            "neck": (("CV7", "SNJ"),),
            "l_shoulder": (("L_SAJ",),),
            "l_elbow": (("L_HLE", "L_HME"), ("L_HLE",)),
            "l_wrist": (("L_RSP", "L_UHE"),),
            "l_hip": (("@hip", "l"),),
            "l_knee": (("L_FLE", "L_FME"), ("L_FLE",)),
            "l_ankle": (("L_FAL", "L_TAM"), ("L_FAL",)),
        }
    ),
    pelvis=(("L_IAS", "R_IAS", "L_IPS", "R_IPS"),),
    clusters=(("L_IAS", "R_IAS", "L_IPS", "R_IPS"),),
    pairs=((("L_IAS", "R_IAS"), ("L_IPS", "R_IPS")),),
)

QUALISYS_SPORTS = MarkerSet(
    "qualisys-sports",
    "Qualisys sports / running full body (LASIS, LBackAsis, LKneeLat, LAnkleLat, LElbowLat, "
    "LWristLat/Med, LAcromium, C7, Sternum, T10)",
    _sides(
        {
            "pelvis": (("LASIS", "RASIS", "LBackAsis", "RBackAsis"),),
            "spine": (("T10", "Sternum"),),
            "sternum": (("Clav", "Sternum"),),
            "neck": (("C7", "Clav"),),
            "l_shoulder": (("LAcromium",),),
            "l_elbow": (("LElbowLat",),),
            "l_wrist": (("LWristLat", "LWristMed"),),
            "l_hip": (("@hip", "l"),),
            "l_knee": (("LKneeLat",),),
            "l_ankle": (("LAnkleLat",),),
        }
    ),
    pelvis=(("LASIS", "RASIS", "LBackAsis", "RBackAsis"),),
    clusters=(("LASIS", "RASIS", "LBackAsis", "RBackAsis"),),
    pairs=((("LASIS", "RASIS"), ("LBackAsis", "RBackAsis")),),
)

MARKER_SETS = {s.name: s for s in (PLUG_IN_GAIT, QUALISYS_ISB, QUALISYS_SPORTS)}

#: the points a set produces, in this order, with a parent each (a tree the view can draw)
JOINTS = (
    "pelvis",
    "spine",
    "sternum",
    "neck",
    "l_shoulder",
    "l_elbow",
    "l_wrist",
    "r_shoulder",
    "r_elbow",
    "r_wrist",
    "l_hip",
    "l_knee",
    "l_ankle",
    "r_hip",
    "r_knee",
    "r_ankle",
)
PARENTS = (-1, 0, 1, 2, 2, 4, 5, 2, 7, 8, 0, 10, 11, 0, 13, 14)


def _index(labels) -> dict:
    """Marker label (without namespace, upper case) -> column."""
    out = {}
    for i, label in enumerate(labels):
        out.setdefault(bare(str(label).strip()).upper(), i)
    return out


def _plan(mset: MarkerSet, index: dict):
    """``(chosen, missing)``: the alternative chosen for each point, and for each point with
    none present the markers of its first alternative that are absent."""
    chosen, missing = {}, {}
    for point in JOINTS:
        for alt in mset.points[point]:
            if alt[0] == "@hip":
                pel = next((p for p in mset.pelvis if all(m.upper() in index for m in p)), None)
                if pel is not None:
                    chosen[point] = ("@hip", alt[1], pel)
                    break
                continue
            if all(m.upper() in index for m in alt):
                chosen[point] = alt
                break
        else:
            first = mset.points[point][0]
            need = mset.pelvis[0] if first[0] == "@hip" else first
            missing[point] = [m for m in need if m.upper() not in index]
    return chosen, missing


def plan(mset: MarkerSet, labels):
    """``(chosen, missing)`` of one marker set for these ``labels`` (see :func:`best_set`)."""
    return _plan(mset, _index(labels))


def best_set(labels):
    """The marker set that covers ``labels`` best: ``(set, chosen, missing)``; ``missing``
    maps the canonical points it cannot make to the markers they lack."""
    index = _index(labels)
    best = None
    for mset in MARKER_SETS.values():
        chosen, missing = _plan(mset, index)
        if best is None or len(chosen) > len(best[1]):
            best = (mset, chosen, missing)
    return best


def joint_positions(
    markers: np.ndarray, labels, chosen: dict, mset: MarkerSet | None = None, min_run: int = 1
) -> np.ndarray:
    """Canonical points from marker trajectories.

    Parameters
    ----------
    markers : ndarray, shape (n_frames, n_markers, 3)
        NaN where a marker is missing; a point made of a missing marker is NaN there, unless
        another alternative of ``mset`` for it is seen there.
    labels : sequence of str
    chosen : dict
        From :func:`best_set` (every point of :data:`JOINTS` present).
    mset : MarkerSet, optional
        The set ``chosen`` comes from: its other alternatives (and pelvis marker sets) fill,
        frame by frame, where the chosen one's markers are lost.
    min_run : int
        An alternative serves runs of at least this many lost frames only (shorter gaps are
        better interpolated: :mod:`streamseg.io.gaps`).

    Returns
    -------
    ndarray of float64, shape (n_frames, len(JOINTS), 3)
    """
    index = _index(labels)

    def mean(names):
        return np.mean([markers[:, index[m.upper()]] for m in names], axis=0)

    def point_of(recipe, pel=None):
        if recipe[0] == "@hip":
            pel = recipe[2] if pel is None else pel
            return bell_hip(mean(pel[:1]), mean(pel[1:2]), mean(pel[2:]), recipe[1])
        return mean(recipe)

    out = np.empty((markers.shape[0], len(JOINTS), 3))
    for j, point in enumerate(JOINTS):
        recipe = chosen[point]
        out[:, j] = point_of(recipe)
        if mset is None:
            continue
        if recipe[0] == "@hip":
            spare = [
                (recipe, p)
                for p in mset.pelvis
                if p != recipe[2] and all(m.upper() in index for m in p)
            ]
        else:
            spare = [
                (alt, None)
                for alt in mset.points[point]
                if alt != recipe and alt[0] != "@hip" and all(m.upper() in index for m in alt)
            ]
        for alt, pel in spare:
            lost = _long_runs(~np.isfinite(out[:, j]).all(axis=1), min_run)
            if not lost.any():
                break
            out[lost, j] = point_of(alt, pel)[lost]
    return out


def _long_runs(mask: np.ndarray, k: int) -> np.ndarray:
    """``mask`` keeping its runs of True at least ``k`` long."""
    if k <= 1 or not mask.any():
        return mask
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    out = np.zeros_like(mask)
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
        if b - a >= k:
            out[a:b] = True
    return out


def bell_hip(lasis: np.ndarray, rasis: np.ndarray, posterior: np.ndarray, side: str) -> np.ndarray:
    """Hip joint centre from the pelvis markers (Bell, Pedersen & Brand 1990).

    In the pelvis frame (origin mid-ASIS; y from the right to the left ASIS, x forward,
    away from the posterior markers, z up) the centre lies 19% of the inter-ASIS distance
    back, 30% down and 36% to the side.

    Parameters
    ----------
    lasis, rasis, posterior : ndarray, shape (n, 3)
        Left and right anterior superior iliac spines; the mean of the posterior markers
        (PSIS or sacrum).
    side : {"l", "r"}

    Returns
    -------
    ndarray, shape (n, 3)
    """
    origin = (lasis + rasis) / 2
    across = lasis - rasis
    d = np.linalg.norm(across, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        y = across / d
        back = posterior - origin
        x = -(back - np.sum(back * y, axis=1, keepdims=True) * y)
        x /= np.linalg.norm(x, axis=1, keepdims=True)
    z = np.cross(x, y)
    lateral = 0.36 if side == "l" else -0.36
    return origin + d * (-0.19 * x + lateral * y - 0.30 * z)
