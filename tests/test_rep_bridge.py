"""Lost joints bridged for the repetition counter (streamseg.online.rep_bridge): the rule
(tests/naive.py), the same frames however the stream is cut, bounded waits; the counter live
equals offline on a real take with markers lost for stretches and for good."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg.io import read
from streamseg.offline.repetition import RepetitionSegmenter
from streamseg.online.rep_bridge import PoseBridge
from streamseg.online.repetition import RepetitionCounter, sets_of, stream_events
from tests.naive import naive_pose_bridge


def _lossy(rng, n=400, J=6):
    """A random walk with lost runs of every length, a joint never seen and a needed joint
    lost at the start and in the middle."""
    P = np.cumsum(rng.normal(size=(n, J, 3)), axis=0)
    for _ in range(25):
        j, a = int(rng.integers(1, J - 1)), int(rng.integers(0, n))
        P[a : a + int(rng.integers(1, 40)), j] = np.nan
    P[:, J - 1] = np.nan  # never seen
    P[:17, 0] = np.nan
    P[150:190, 0] = np.nan
    return P


def _stream(P, chunks, hold=8, needed=(0,)):
    b = PoseBridge(P.shape[1], hold, needed)
    outs, gots, at = [], [], 0
    for size in chunks:
        o, g = b.push(P[at : at + size])
        at += size
        outs.append(o)
        gots.append(np.arange(b.n_out - o.shape[0], b.n_out) + 1 if g is None else g)
        # a frame waits at most `hold` frames once the take has its first needed frame
        assert b.n_in - b.n_out <= hold or b.n_out == 0
    o, g = b.finish()
    outs.append(o)
    gots.append(np.arange(b.n_out - o.shape[0], b.n_out) + 1 if g is None else g)
    return np.concatenate(outs), np.concatenate(gots), b


@pytest.mark.parametrize("seed", range(6))
def test_the_bridge_follows_its_rule_however_the_stream_is_cut(seed):
    rng = np.random.default_rng(seed)
    P = _lossy(rng)
    want = naive_pose_bridge(P, 8, (0,))
    results = []
    for chunks in ([P.shape[0]], [1] * P.shape[0], rng.integers(1, 30, size=100).tolist()):
        chunks = chunks + [P.shape[0]]  # what is left
        out, got, b = _stream(P, chunks)
        assert out.shape == P.shape
        np.testing.assert_allclose(out, want, equal_nan=True)
        results.append(got)
        assert sorted(b.long_lost)[-1] == P.shape[1] - 1
    # the frame each was decided at is the stream's, not the packets'
    assert all(np.array_equal(results[0][:-60], r[:-60]) for r in results[1:])
    assert (results[1] >= np.arange(1, P.shape[0] + 1)).all()


def test_a_take_without_a_trunk_releases_nothing():
    P = np.full((50, 3, 3), np.nan)
    P[:, 1] = 0.0
    out, got, _ = _stream(P, [10] * 5)
    assert out.shape[0] == 0 and naive_pose_bridge(P, 8, (0,)) is None


def test_complete_frames_pass_through_untouched():
    P = np.random.default_rng(0).normal(size=(30, 4, 3))
    b = PoseBridge(4, 5, (0,))
    out, got = b.push(P)
    assert out is P and got is None


@pytest.fixture(scope="module")
def lossy_squat(data_dir):
    """UI-PRMD m01 s01 (Vicon deep squat, 100 Hz): the left wrist never seen, the left knee
    lost in most frames in runs of 0.05-2 s, the whole body gone for 0.3 s twice."""
    rec = read(data_dir / "uiprmd" / "vicon" / "m01_s01.trc.gz")
    P = rec.positions.copy()
    j = rec.skeleton.index
    P[:, j("l_wrist")] = np.nan
    rng = np.random.default_rng(1)
    n = P.shape[0]
    for a in rng.integers(0, n, size=40):
        P[a : a + int(rng.integers(5, 200)), j("l_knee")] = np.nan
    P[900:930] = np.nan
    P[2100:2130] = np.nan
    from dataclasses import replace

    return replace(rec, positions=P)


def test_live_counts_equal_offline_on_a_take_with_lost_markers(lossy_squat):
    """Every set and every event the same fed 1, 13 or 100 frames a call, and as
    ``segment --method rep`` counts (which still finds the ten squats)."""
    rec = lossy_squat
    seg = RepetitionSegmenter().fit(rec)
    assert seg.count_ == 10 and "l_wrist" in seg.lost_joints_
    runs = []
    for chunk in (1, 13, 100):
        c = RepetitionCounter(fps=rec.fps, skeleton=rec.skeleton)
        events = stream_events(c, rec.positions, chunk)
        runs.append(
            [(e.start, e.end, e.count, e.emitted_at, e.rom_deg, e.likeness) for e in events]
        )
        assert sets_of(events) == [s["repetitions"] for s in seg.sets_]
        assert "l_wrist" in c.lost_joints_ and "l_knee" in c.lost_joints_
    assert runs[0] == runs[1] == runs[2]
    # an event is never stamped before the frames that decided it arrived
    assert all(e[3] >= e[1] for e in runs[0])


@pytest.mark.daemon
def test_a_daemon_counts_a_take_with_lost_markers_as_offline(start_daemon, lossy_squat):
    """A real daemon fed the take by ``replay`` over ZeroMQ: every ``rep`` event (its
    duration, range of motion and likeness too) what the counter gives offline on the file's
    frames (gaps up to 0.25 s filled, as a reader and the daemon's gap filler do),
    a warning naming the joint lost; the frames the cut detector cannot use are still
    counted in the ``nan`` error."""
    from streamseg.client import listen, subscribe
    from streamseg.commands.replay import replay
    from streamseg.daemon.algorithms import Algorithms
    from streamseg.io import with_gaps_filled

    rec = with_gaps_filled(lossy_squat)
    d, ep = start_daemon(Algorithms(repetitions=True))
    s = subscribe(ep["publish"], ep["control"], stream="lossy")
    replay(rec, ep["ingest"], stream="lossy", speed=0, batch=25)
    events = list(listen(s, stream="lossy", until_end=True, timeout=60))
    c = RepetitionCounter(fps=rec.fps, skeleton=rec.skeleton)
    want = c.learn_many(rec.positions) + c.finish()
    got = [
        (e.start, e.end, e.count, e.emitted_at, e.duration_s, e.rom_deg, e.rom_joint, e.likeness)
        for e in events
        if e.type == "rep"
    ]
    assert len(want) == 10
    assert got == [
        (r.start, r.end, r.count, r.emitted_at, r.duration_s, r.rom_deg, r.rom_joint, r.likeness)
        for r in want
    ]
    # what a therapist reads of each repetition travels with it: a deep squat's knee range
    assert all(g[6] in ("l_knee", "r_knee", "l_hip", "r_hip") and g[5] > 90 for g in got)
    assert all(0 <= g[7] <= 1 for g in got) and all(g[4] > 0.5 for g in got)
    errors = [e for e in events if e.type == "error"]
    warned = [e.message for e in errors if e.reason == "rep"]
    assert warned and "l_wrist" in warned[0] and "lost for more than 0.5 s" in warned[0]
    assert [e.count for e in errors if e.reason == "nan"][-1] > 0
