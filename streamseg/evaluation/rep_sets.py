"""Labelled repetition material built from the HDM05 one-repetition clips (data/hdm05_reps).

Each clip of the five repetitive classes holds exactly one repetition, so consecutive takes of
one actor and class joined are a *set* whose true boundaries are the joins, and sets of
several classes, with whole-action clips between some of them, a *routine* (every join is
abrupt: the clips start and end near their class's key pose but no person made the
transition). Every choice below is fixed by the arguments (stable seeds), before any result.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from streamseg.evaluation.datasets import (
    HDM05_ACTIONS,
    HDM05_REPETITIVE,
    hdm05_clips,
)

__all__ = ["RepSetPlan", "hdm05_rep_sets", "hdm05_routines", "load_plan"]

#: Set sizes of the benchmark (the issue's 2, 3, 4, 6 and 10 repetitions).
SET_SIZES = (2, 3, 4, 6, 10)


@dataclass(frozen=True)
class RepSetPlan:
    """Which clips make one labelled sequence.

    Attributes
    ----------
    name : str
    actor : str
    parts : tuple of (class, (path, ...))
        In order; a repetitive class's paths are one set (one repetition each), an action
        class's one clip.
    """

    name: str
    actor: str
    parts: tuple


def _rng(*key) -> np.random.Generator:
    return np.random.default_rng(zlib.crc32("/".join(map(str, key)).encode()))


def hdm05_rep_sets(
    data_dir,
    actors=("bd", "bk", "dg"),
    sizes=SET_SIZES,
    per: int | None = 4,
    classes=HDM05_REPETITIVE,
) -> list[RepSetPlan]:
    """Sets of ``sizes`` consecutive takes of one actor and class.

    Up to ``per`` windows of consecutive takes (None: every window), their first takes
    evenly spaced over the actor's takes of the class; a class with fewer takes than the size
    gets two draws with replacement (dg has two arm-circle takes: its sets repeat takes).
    """
    clips = hdm05_clips(data_dir)
    out = []
    for cls in classes:
        for actor in actors:
            takes = clips.get((actor, cls), [])
            for k in sizes:
                if len(takes) >= k:
                    n_win = len(takes) - k + 1 if per is None else per
                    starts = sorted(
                        set(np.linspace(0, len(takes) - k, n_win).round().astype(int).tolist())
                    )
                    picks = [list(range(s, s + k)) for s in starts]
                else:
                    rng = _rng(cls, actor, k)
                    picks = [
                        rng.choice(len(takes), size=k, replace=True).tolist() for _ in range(2)
                    ]
                for i, idx in enumerate(picks):
                    out.append(
                        RepSetPlan(
                            f"{cls}/{actor}/{k}/{i}", actor, ((cls, tuple(takes[j] for j in idx)),)
                        )
                    )
    return out


def hdm05_routines(
    data_dir, actors=("bd", "bk", "dg"), per_actor: int = 6, p_action: float = 0.6
) -> list[RepSetPlan]:
    """Routines: the five repetitive classes in a random order, each a set of 2-6
    consecutive takes (first take random, wrapping round), followed with probability
    ``p_action`` by one whole-action clip; so some exercises follow each other directly."""
    clips = hdm05_clips(data_dir)
    out = []
    for actor in actors:
        rng = _rng("routine", actor)
        for r in range(per_actor):
            parts = []
            for cls in rng.permutation(HDM05_REPETITIVE).tolist():
                takes = clips[actor, cls]
                k = int(rng.integers(2, 7))
                s = int(rng.integers(0, max(1, len(takes) - k + 1)))
                parts.append((cls, tuple(takes[(s + j) % len(takes)] for j in range(k))))
                if rng.random() < p_action:
                    act = HDM05_ACTIONS[int(rng.integers(len(HDM05_ACTIONS)))]
                    pool = clips[actor, act]
                    parts.append((act, (pool[int(rng.integers(len(pool)))],)))
            out.append(RepSetPlan(f"routine/{actor}/{r}", actor, tuple(parts)))
    return out


def load_plan(data_dir, plan: RepSetPlan, cache: dict | None = None):
    """Read and join a plan's clips.

    Returns
    -------
    recording : Recording
    truth : list of (start, end, class, repetitions)
        One entry per part; ``repetitions`` the true ``(start, end)`` of each repetition of
        a repetitive set (one per clip), empty for an action clip.
    """
    from streamseg.io import read
    from streamseg.recording import Recording

    asf = Path(data_dir) / "hdm05_reps" / "asf" / f"HDM_{plan.actor}.asf"
    cache = {} if cache is None else cache
    pos, truth, at, skeleton = [], [], 0, None
    for cls, paths in plan.parts:
        reps = []
        for p in paths:
            if p not in cache:
                cache[p] = read(p, skeleton=asf)
            r = cache[p]
            skeleton = r.skeleton
            pos.append(r.positions)
            reps.append((at, at + r.n_frames))
            at += r.n_frames
        truth.append((reps[0][0], at, cls, reps if cls in HDM05_REPETITIVE else []))
    return Recording(120.0, skeleton, np.concatenate(pos), source=plan.name), truth
