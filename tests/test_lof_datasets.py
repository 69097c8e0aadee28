"""Concatenated evaluation sequences and the Recording path of the offline segmenter."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg import io, skeleton
from streamseg.config import LOFConfig
from streamseg.exceptions import ParameterError
from streamseg.offline.lof import LOFSegmenter


def test_cmu02_sequence_joins_clips_at_the_true_cuts(data_dir):
    from streamseg.evaluation.datasets import CMU02_SEQUENCES, cmu02_sequence, concatenate

    trials = CMU02_SEQUENCES["02_walk_punch_sword_wash"]
    rec, cuts = cmu02_sequence(data_dir, trials)
    parts = [
        io.read(data_dir / "cmu02" / f"02_{t}.amc.gz", skeleton=data_dir / "cmu02" / "02.asf")
        for t in trials
    ]
    lengths = [p.n_frames for p in parts]
    assert cuts == list(np.cumsum(lengths)[:-1]) and rec.n_frames == sum(lengths)
    np.testing.assert_array_equal(rec.positions[cuts[1] : cuts[2]], parts[2].positions)
    assert rec.metadata["cuts"] == cuts
    with pytest.raises(ParameterError, match="fps"):
        concatenate([parts[0], parts[1].__class__(60.0, parts[1].skeleton, parts[1].positions)])
    from dataclasses import replace

    z_up = replace(parts[1], skeleton=replace(parts[1].skeleton, up="z"))
    with pytest.raises(ParameterError, match="up axis"):
        concatenate([parts[0], z_up])


def test_cmu02_sequences_follow_the_single_action_rule(data_dir):
    from streamseg.evaluation.datasets import (
        CMU02_MIN_SECONDS,
        CMU02_MULTI_ACTION_SEQUENCES,
        CMU02_SEQUENCES,
        CMU02_TRIAL_ACTIONS,
    )

    asf = data_dir / "cmu02" / "02.asf"
    seconds = {
        t: io.read(data_dir / "cmu02" / f"02_{t}.amc.gz", skeleton=asf).n_frames / 120
        for t in CMU02_TRIAL_ACTIONS
    }
    ok = {
        t
        for t, acts in CMU02_TRIAL_ACTIONS.items()
        if len(acts) == 1 and seconds[t] >= CMU02_MIN_SECONDS
    }
    assert ok == {"01", "05", "07", "08", "09", "10"}
    orders = []
    for trials in CMU02_SEQUENCES.values():
        assert set(trials) <= ok
        actions = [CMU02_TRIAL_ACTIONS[t] for t in trials]
        assert len(set(actions)) == len(actions)  # each action once: every join is a change
        orders.append(tuple(actions))
    assert len(set(orders)) == len(orders) == 2
    assert all(not set(t) <= ok for t in CMU02_MULTI_ACTION_SEQUENCES.values())


def test_fit_recording_equals_fit_bone_angles(data_dir):
    from streamseg.online.root_speed import root_speed_columns

    rec = io.read(data_dir / "cmu86" / "86_01.amc.gz", skeleton=data_dir / "cmu86" / "86.asf")
    a = LOFSegmenter(LOFConfig(), rec.fps).fit(rec)
    b = LOFSegmenter(LOFConfig(), rec.fps).fit(
        np.column_stack(
            [
                skeleton.bone_angles(rec.positions, rec.skeleton, inclinations=True),
                root_speed_columns(rec.positions, rec.skeleton, rec.fps),
            ]
        )
    )
    np.testing.assert_array_equal(a.lof_, b.lof_)
    np.testing.assert_array_equal(a.predict(), b.predict())
    assert a.n_frames_ == rec.n_frames


def test_hdm05_action_plans_use_each_clip_once_and_cut_between_classes(data_dir):
    from streamseg.evaluation.datasets import (
        HDM05_ACTIONS,
        HDM05_REPETITIVE,
        HDM05_SET_REPS,
        hdm05_action_plans,
        hdm05_sequence,
    )

    plans = hdm05_action_plans(data_dir)
    assert len(plans) == 9
    used = [p for _actor, parts in plans.values() for _c, paths in parts for p in paths]
    assert len(used) == len(set(used))
    for actor, parts in plans.values():
        classes = [c for c, _ in parts]
        assert len(set(classes)) == 5
        assert set(classes) & set(HDM05_REPETITIVE) and set(classes) & set(HDM05_ACTIONS)
        for c, paths in parts:
            assert len(paths) == (HDM05_SET_REPS if c in HDM05_REPETITIVE else 1)
            assert all(f"HDM_{actor}_{c}_" in p.name for p in paths)
    actor, parts = plans["hdm_bd_0"]
    rec, cuts = hdm05_sequence(data_dir, actor, parts)
    from streamseg.io import read

    asf = data_dir / "hdm05_reps/asf/HDM_bd.asf"
    lengths = [sum(read(p, skeleton=asf).n_frames for p in paths) for _c, paths in parts]
    assert cuts == list(np.cumsum(lengths)[:-1]) and rec.n_frames == sum(lengths)


def test_hdm05_action_plans_exclude_gives_sequences_of_unused_clips(data_dir):
    # 49fb205:benchmarks/lof_confirm.py's fresh held-out joins: none of their clips is in the nine
    from streamseg.evaluation.datasets import hdm05_action_plans

    old = hdm05_action_plans(data_dir)
    fresh = hdm05_action_plans(data_dir, seed=11, exclude=old, prefix="fresh")
    assert sorted(fresh) == sorted(n.replace("hdm_", "fresh_") for n in old)

    def clips(plans):
        return {p for _actor, parts in plans.values() for _c, paths in parts for p in paths}

    assert clips(fresh) and not clips(fresh) & clips(old)
    # without exclude the same seed draws from every clip, reusing some of the nine's
    assert clips(hdm05_action_plans(data_dir, seed=11)) & clips(old)
