"""Repetition benchmark material: HDM05 repetition sequences, Kinect-like degradation, cache.

Sequences: 3-8 real HDM05 single-repetition clips of one actor and one class concatenated in
take order (subsets drawn with a fixed seed); the true repetition boundaries are the joins
(abrupt: no natural transition, though each clip starts and ends near the rest pose). dg has
only two rotateArmsBothBackward clips, so its sequences repeat clips (drawn with
replacement). "Kinect-like": every 4th frame (120 -> 30 Hz) plus Gaussian noise of 2.5 cm on
every coordinate (positions are in metres, see ``Skeleton.units``).

The UKF (the slow part) depends only on the positions and the UKF settings, so its output (the
bone directions the segmenter analyses) is cached in ``.bench_cache/`` under a key of both:
choosing the section-4 parameters then costs only the analysis.
"""

from __future__ import annotations

import csv
import hashlib
from collections import defaultdict
from dataclasses import fields
from pathlib import Path

import numpy as np

from streamseg.config import RepetitionConfig
from streamseg.io import read
from streamseg.recording import Recording, Skeleton

DATA = Path(__file__).resolve().parents[1] / "data"
CACHE = Path(__file__).resolve().parents[1] / ".bench_cache"
KINECT_FPS_STEP = 4  # 120 Hz -> 30 Hz
KINECT_NOISE_M = 0.025
CONDITIONS = ("clean", "kinect")
UKF_FIELDS = ("position_noise", "angle_speed", "estimate_noise", "length_speed", "ukf_passes",
              "torso_cutoff_hz")


def load_clips():
    """{(class, actor): [positions (n, J, 3), ...]} and {actor: joint names}, from clips.csv."""
    clips, names = defaultdict(list), {}
    with open(DATA / "hdm05_reps" / "clips.csv", newline="") as fh:
        for row in csv.DictReader(fh):
            path = DATA / "hdm05_reps" / row["class"] / (row["file"] + ".gz")
            asf = DATA / "hdm05_reps" / "asf" / f"HDM_{row['actor']}.asf"
            rec = read(path, skeleton=asf)
            assert rec.skeleton.units == "m", rec.skeleton.units
            clips[(row["class"], row["actor"])].append(rec.positions)
            names[row["actor"]] = rec.skeleton.names
    return clips, names


def kinectify(pos, reps, rng):
    """30 Hz and 2.5 cm noise; repetition boundaries mapped to the new frame numbers."""
    sub = pos[::KINECT_FPS_STEP]
    sub = sub + rng.normal(0.0, KINECT_NOISE_M, sub.shape)
    n = sub.shape[0]

    def m(f):
        return min(n, int(np.ceil(f / KINECT_FPS_STEP)))

    return sub, [(m(a), m(b)) for a, b in reps]


def make_sequences(clips, names, per_pair, seed, classes=None):
    """Sequences as dicts: cls, actor, cond, fps, recording, reps (true repetitions), key.

    Each drawn sequence appears twice: clean (120 Hz) and Kinect-like (30 Hz + noise).
    """
    rng = np.random.default_rng(seed)
    noise = np.random.default_rng(seed + 1)
    out = []
    for (cls, actor), group in sorted(clips.items()):
        if classes is not None and cls not in classes:
            continue
        for i in range(per_pair):
            k = int(rng.integers(3, 9))
            if len(group) >= k:
                idx = np.sort(rng.choice(len(group), size=k, replace=False))
            else:
                idx = rng.choice(len(group), size=k, replace=True)
            parts = [group[j] for j in idx]
            bounds = np.cumsum([0] + [p.shape[0] for p in parts])
            reps = [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]
            pos = np.concatenate(parts)
            sk = Skeleton(names[actor], np.zeros(len(names[actor]), int),
                          np.zeros((len(names[actor]), 3)), "m")
            tag = f"{cls}/{actor}/{seed}/{i}/" + ",".join(map(str, idx))
            for cond in CONDITIONS:
                if cond == "kinect":
                    p, r = kinectify(pos, reps, noise)
                    fps = 120.0 / KINECT_FPS_STEP
                else:
                    p, r, fps = pos, reps, 120.0
                out.append({"cls": cls, "actor": actor, "cond": cond, "fps": fps, "reps": r,
                            "recording": Recording(fps, sk, p, source=tag),
                            "key": f"{tag}/{cond}"})
    return out


def parse_set(items, base: RepetitionConfig) -> dict:
    """``["field=value", ...]`` (``--set``) -> a dict of typed RepetitionConfig changes."""
    types = {f.name: type(getattr(base, f.name)) for f in fields(base)}
    out = {}
    for item in items:
        k, _, v = item.partition("=")
        if k not in types:
            raise SystemExit(f"--set {item}: no RepetitionConfig field {k!r}")
        t = types[k]
        out[k] = (v.lower() in ("1", "true", "yes")) if t is bool else t(v)
    return out


def ukf_key(cfg: RepetitionConfig) -> str:
    return "_".join(f"{getattr(cfg, f)}" for f in UKF_FIELDS)


def bone_features(seq, cfg: RepetitionConfig, cache: Path | None = CACHE) -> np.ndarray:
    """The bone directions :class:`RepetitionSegmenter` analyses for ``seq``, cached."""
    from streamseg.kinematics.model import bone_directions
    from streamseg.offline.repetition import angles_from_positions

    rec = seq["recording"]
    h = hashlib.sha1((seq["key"] + "|" + ukf_key(cfg)).encode()).hexdigest()[:20]
    # the noise is drawn in sequence order: the positions are part of the key too
    h += hashlib.sha1(np.ascontiguousarray(rec.positions[::7]).tobytes()).hexdigest()[:8]
    path = None if cache is None else cache / f"{h}.npy"
    if path is not None and path.exists():
        return np.load(path)
    X = bone_directions(angles_from_positions(rec.positions, rec.skeleton.names, rec.fps, cfg))
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.save(path, X)
    return X


def features(seq, cfg: RepetitionConfig, cache: Path | None = CACHE) -> np.ndarray:
    """What :class:`RepetitionSegmenter` with ``cfg`` analyses for ``seq``: the cached bone
    directions and, with ``cfg.root_height_weight > 0``, the root height (not cached: cheap)."""
    from streamseg.offline.root_height import with_root_height

    return with_root_height(bone_features(seq, cfg, cache), seq["recording"], cfg)


def single_clips(seed: int, cfg: RepetitionConfig):
    """Every clip of ``clips.csv`` alone, clean and Kinect-like (``seed`` draws the noise):
    yields ``(row, kind, condition, seq, fps)``, ``kind`` "repetition" or "action", ``seq``
    for :func:`features` (the UKF run with ``cfg``'s settings and cached here)."""
    from streamseg.evaluation.datasets import HDM05_REPETITIVE

    rng = np.random.default_rng(seed + 7)
    root = DATA / "hdm05_reps"
    with open(root / "clips.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    for row in table:
        rec = read(root / row["class"] / (row["file"] + ".gz"),
                   skeleton=root / "asf" / f"HDM_{row['actor']}.asf")
        kind = "repetition" if row["class"] in HDM05_REPETITIVE else "action"
        for cond in ("clean", "kinect"):
            pos, fps = rec.positions, rec.fps
            if cond == "kinect":
                pos = kinectify(pos, [], rng)[0]
                fps = rec.fps / KINECT_FPS_STEP
            seq = {"recording": Recording(fps, rec.skeleton, pos, source=row["file"]),
                   "key": f"clip/{row['file']}/{cond}/{seed}"}
            bone_features(seq, cfg)  # fills the cache
            yield row, kind, cond, seq, fps
