"""Gaps: one mechanism for files and streams (streamseg.io.gaps), and truncated files."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from streamseg.cli import main
from streamseg.io import read
from streamseg.io.gaps import GapFiller, fill_frames, fill_gaps


def naive_fill(pos: np.ndarray, max_frames: int) -> np.ndarray:
    """Each joint's NaN runs between two finite frames, up to ``max_frames`` long, filled
    linearly; everything else left as is (the obvious twin of GapFiller)."""
    out = pos.astype(np.float64).copy()
    n, n_joints = pos.shape[:2]
    for j in range(n_joints):
        ok = np.isfinite(pos[:, j]).all(axis=1)
        i = 0
        while i < n:
            if ok[i]:
                i += 1
                continue
            k = i
            while k < n and not ok[k]:
                k += 1
            if i > 0 and k < n and k - i <= max_frames:
                for f in range(i, k):
                    t = (f - (i - 1)) / (k - (i - 1))
                    out[f, j] = pos[i - 1, j] + (pos[k, j] - pos[i - 1, j]) * t
            i = k
    return out


def holes(rng, n, n_joints, count):
    pos = np.cumsum(rng.normal(size=(n, n_joints, 3)), axis=0)
    for _ in range(count):
        j, a, length = rng.integers(n_joints), rng.integers(n), rng.integers(1, 25)
        pos[a : a + length, j] = np.nan
    return pos


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    max_frames=st.integers(0, 15),
    cuts=st.lists(st.integers(1, 299), max_size=12),
)
def test_streamed_equals_whole_equals_naive(seed, max_frames, cuts):
    """Any packetisation of a stream gives the frames a whole file gets, bit for bit."""
    rng = np.random.default_rng(seed)
    pos = holes(rng, 300, 4, 12)
    want = naive_fill(pos, max_frames)
    filler = GapFiller(4, max_frames)
    got, edges = [], [0, *sorted(set(cuts)), 300]
    for a, b in zip(edges[:-1], edges[1:]):
        out, start = filler.push(pos[a:b], a if a == 0 else None)
        assert start == sum(x.shape[0] for x in got)
        got.append(out)
    got.append(filler.finish()[0])
    got = np.concatenate(got)
    assert np.array_equal(np.isnan(got), np.isnan(want))
    np.testing.assert_allclose(np.nan_to_num(got), np.nan_to_num(want), rtol=0, atol=1e-12)
    whole, report = fill_gaps(pos, 1.0, max_frames)
    assert np.array_equal(np.nan_to_num(whole), np.nan_to_num(got))
    missing = np.isnan(got).any(axis=(1, 2))
    runs = [(s, e) for s, e, _ in filler.take_gaps()]
    assert runs == report.gaps
    flags = np.zeros(300, bool)
    for s, e in runs:
        flags[s:e] = True
    assert np.array_equal(flags, missing)


def test_holds_only_what_may_still_be_filled():
    filler = GapFiller(1, 3)
    pos = np.arange(10, dtype=float).reshape(10, 1, 1).repeat(3, axis=2)
    pos[8:] = np.nan
    out, _ = filler.push(pos, 0)
    assert out.shape[0] == 8 and filler.held == 2  # frames 8, 9 may be a short gap
    nan = np.full((1, 1, 3), np.nan)
    out, _ = filler.push(nan)
    assert out.shape[0] == 0 and filler.held == 3  # 3 frames: still short enough
    out, start = filler.push(nan)
    assert (start, out.shape[0], filler.held) == (8, 4, 0)  # now 4 long: released as NaN
    assert np.isnan(out).all()
    out, start = filler.push(np.ones((1, 1, 3)))
    assert (start, out.shape[0]) == (12, 1)
    assert [g[:2] for g in filler.take_gaps()] == [(8, 12)]


def test_the_cli_default_is_the_library_default():
    from streamseg.commands import inputs
    from streamseg.io import gaps

    assert inputs.FILL_S == gaps.FILL_S


def test_fill_frames_of_seconds():
    assert fill_frames(120, 0.25) == 30 and fill_frames(30, 0.25) == 7 and fill_frames(100, 0) == 0
    with pytest.raises(ValueError):
        fill_frames(120, -1)


def test_lost_flags_mark_gaps_made_of_lost_frames_only():
    filler = GapFiller(1, 2)
    pos = np.zeros((20, 1, 3))
    pos[5:10] = np.nan
    pos[12:15] = np.nan
    lost = np.zeros(20, bool)
    lost[5:10] = True
    lost[12:14] = True
    filler.push(pos, 0, lost)
    filler.finish()
    assert filler.take_gaps() == [(5, 10, True), (12, 15, False)]


@pytest.fixture(scope="module")
def take_with_gaps(tmp_path_factory, rec):
    """86_01 as a positions CSV with real-looking dropouts: short ones (filled) and two long
    ones (skipped)."""
    from streamseg.io.positions import read_positions

    path = tmp_path_factory.mktemp("gaps") / "86_01.csv"
    pos = rec.positions.copy()
    rng = np.random.default_rng(7)
    for _ in range(40):  # short marker dropouts, at most 0.1 s
        j, a = rng.integers(pos.shape[1]), rng.integers(100, 4400)
        pos[a : a + rng.integers(1, 13), j] = np.nan
    pos[1500:1620, :] = np.nan  # 1 s without any joint
    lk = rec.skeleton.index("lfemur")
    pos[3000:3100, lk] = np.nan  # the left knee lost for 0.83 s
    header = ",".join(f"{n}_{a}" for n in rec.skeleton.names for a in "xyz")
    rows = np.where(np.isnan(pos), np.nan, pos).reshape(pos.shape[0], -1)
    with open(path, "w") as fh:
        fh.write(header + "\n")
        for r in rows:
            fh.write(",".join("" if np.isnan(v) else repr(float(v)) for v in r) + "\n")
    assert np.isnan(read_positions(path, fps=120).positions).any()
    return path


def test_a_file_with_gaps_segments_with_a_warning(take_with_gaps, capsys):
    rc = main(["segment", str(take_with_gaps), "--fps", "120", "--json"])
    out, err = capsys.readouterr()
    assert rc == 0
    res = json.loads(out)
    assert [(g["start"], g["end"]) for g in res["gaps"]] == [(1500, 1620), (3000, 3100)]
    assert res["filled_frames"] > 100
    assert "2 gaps without the joint positions the features use, longer than 0.25 s" in err
    assert "skipped by the detectors" in err and any("2 gaps" in w for w in res["warnings"])
    assert res["cuts"]  # the rest of the take is still cut
    assert not any(1500 < c < 1620 for c in res["cuts"])


def test_gap_fill_zero_fills_nothing(take_with_gaps):
    rec = read(take_with_gaps, fps=120, gap_fill=0)
    assert rec.metadata["filled_frames"] == 0 and len(rec.metadata["gaps"]) > 2


def test_truncated_take_keeps_its_good_frames_by_default(tmp_path, data_dir, capsys):
    import gzip

    text = (
        gzip.decompress((data_dir / "cmu86" / "86_01.amc.gz").read_bytes())
        .decode("latin-1")
        .replace("\r\n", "\n")
    )
    cut = text[: text.index("\n2292\n") + 40]  # frame 2292 cut off mid-line
    f = tmp_path / "cut.amc"
    f.write_text(cut)
    asf = str(data_dir / "cmu86" / "86.asf")
    rc = main(["segment", str(f), "--skeleton", asf, "--json"])
    out, err = capsys.readouterr()
    assert rc == 0
    res = json.loads(out)
    assert res["n_frames"] == 2291
    assert "the file was cut off): dropped it, kept 2291 frames" in err
    assert main(["segment", str(f), "--skeleton", asf, "--strict"]) == 2
    err = capsys.readouterr().err
    assert "truncated last frame" in err and "2291 good frame(s)" in err


def test_truncated_npy_and_csv_keep_whole_frames(tmp_path, data_dir, rec):
    from streamseg.exceptions import TruncatedRecordingError

    src = np.load(data_dir / "sources" / "keraal" / "blazepose_ctk.npy")
    npy = tmp_path / "take.npy"
    np.save(npy, src)
    npy.write_bytes(npy.read_bytes()[:-200])  # cut inside the last frame
    with pytest.raises(TruncatedRecordingError, match="whole frames"):
        read(npy, joints="blazepose", fps=30)
    r = read(npy, joints="blazepose", fps=30, lenient=True)
    assert r.n_frames == src.shape[0] - 1
    assert "1 dropped" in r.metadata["warnings"][0]
    np.testing.assert_array_equal(r.positions[:, :33], src[:-1])

    pos = rec.positions[:300]
    names = ",".join(f"{n}_{a}" for n in rec.skeleton.names for a in "xyz")
    csv = tmp_path / "take.csv"
    lines = [names] + [",".join(repr(float(v)) for v in r) for r in pos.reshape(300, -1)]
    csv.write_text("\n".join(lines)[:-30])
    r = read(csv, fps=120, lenient=True)
    assert r.n_frames == 299 and "dropped 1 frame, kept 299" in r.metadata["warnings"][0]


@pytest.mark.daemon
def test_the_daemon_gap_fill_is_a_setting(data_dir, start_daemon, tmp_path, capsys):
    """`serve --gap-fill` (DaemonConfig.gap_fill, TOML `gap_fill`): a 0.4 s hole in the left
    knee is a skipped gap at the default 0.25 s and filled at 0.5 s, live as in
    `segment --online --gap-fill` on the file."""
    from dataclasses import replace

    from streamseg.client import listen, subscribe
    from streamseg.commands.replay import replay
    from streamseg.commands.serve import build
    from streamseg.config import DaemonConfig
    from streamseg.daemon import Daemon
    from streamseg.io import write_npz
    from streamseg.io.gaps import FILL_S

    assert DaemonConfig().gap_fill == FILL_S  # one default for files and live streams
    from streamseg.cli import build_parser

    args = build_parser().parse_args(["serve", "--gap-fill", "0.5", "--state-dir", "none"])
    config, algorithms = build(args)
    assert config.gap_fill == 0.5
    assert Daemon(config, algorithms).algorithms.gap_fill_s == 0.5

    rec = read(data_dir / "cmu86" / "86_01.amc.gz", skeleton=data_dir / "cmu86" / "86.asf")
    rec = replace(rec, positions=rec.positions[:1800].copy(), rotations=None, metadata={})
    knee = rec.skeleton.index("lfemur")
    rec.positions[900:948, knee] = np.nan  # 0.4 s at 120 Hz
    holes = tmp_path / "holes.npz"
    write_npz(holes, rec)
    for fill, filled in ((None, False), (0.5, True)):
        flag = [] if fill is None else ["--gap-fill", str(fill)]
        assert main(["segment", str(holes), "--online", "--json", *flag]) == 0
        want = json.loads(capsys.readouterr().out)
        assert [(g["start"], g["end"]) for g in want["gaps"]] == ([] if filled else [(900, 948)])
        _, ep = start_daemon(**({} if fill is None else {"gap_fill": fill}))
        sub = subscribe(ep["publish"], ep["control"], stream="g")
        replay(read(holes, gap_fill=0), ep["ingest"], stream="g", speed=0, batch=7)
        events = list(listen(sub, stream="g", until_end=True, timeout=60))
        assert [e.frame for e in events if e.type == "cut"] == want["cuts"]
        gaps = [(e.expected, e.got, e.filled) for e in events if e.type == "gap"]
        assert gaps == ([] if filled else [(900, 948, False)])
