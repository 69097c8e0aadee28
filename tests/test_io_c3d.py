"""C3D in (markers mapped to joints) and out (segments written as C3D events), on real files
of Vicon, Qualisys and OptiTrack systems (data/sources, README there)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.config import LOFConfig
from streamseg.exceptions import RecordingError, TruncatedRecordingError
from streamseg.io import read
from streamseg.offline.lof import position_features
from streamseg.offline.lof_report import lof_report

pytest.importorskip("ezc3d")

from streamseg.io.c3d import read_events, write_events  # noqa: E402


@pytest.fixture(scope="module")
def c3d_dir(data_dir):
    return data_dir / "sources" / "c3d"


def cuts_s(rec) -> list[float]:
    cfg = LOFConfig()
    feats = position_features(rec.positions, rec.skeleton, rec.fps, cfg)
    return [c / rec.fps for c in lof_report(feats, rec.fps, cfg, False)["cuts"]]


def test_vicon_take_cuts_like_its_amc_and_bvh(c3d_dir, data_dir):
    """CMU 01_01 as Vicon markers (Plug-in Gait set), as the solved AMC and as a BVH on a
    Character Creator rig: the same cuts, within 0.25 s."""
    c3d = read(c3d_dir / "cmu_01_01.c3d")
    assert c3d.metadata["marker_set"] == "plug-in-gait" and c3d.skeleton.up == "z"
    assert (c3d.n_frames, c3d.fps, c3d.metadata["manufacturer"]) == (2751, 120.0, "")
    amc = read(
        data_dir / "sources" / "cmu01" / "01_01.amc.gz",
        skeleton=data_dir / "sources" / "cmu01" / "01.asf",
    )
    bvh = read(data_dir / "sources" / "bvh" / "cc_01_01.bvh.gz")
    a, b, c = cuts_s(amc), cuts_s(bvh), cuts_s(c3d)
    assert a and len(a) == len(b) == len(c)
    assert np.abs(np.subtract(a, c)).max() <= 0.25 and np.abs(np.subtract(a, b)).max() <= 0.25


@pytest.mark.parametrize(
    "name,system,units,n,fps",
    [
        ("vicon_pig_stairs.c3d", "Vicon", "mm", 323, 120.0),
        ("optitrack_tennis_serve.c3d", "OptiTrack", "m", 1092, 50.0),
    ],
)
def test_plug_in_gait_full_body_of_two_systems(c3d_dir, name, system, units, n, fps):
    """Real Plug-in Gait full-body takes (LASI RASI LPSI RPSI, LKNE, LANK, LSHO, LELB,
    LWRA/LWRB ...): Vicon Nexus with its model outputs among the labels, and OptiTrack Motive
    with a subject namespace (``Derrick:LASI``)."""
    from streamseg.skeleton.marker_sets import best_set

    rec = read(c3d_dir / name)
    assert rec.metadata["marker_set"] == "plug-in-gait"
    assert (rec.metadata["manufacturer"], rec.skeleton.units, rec.n_frames, rec.fps) == (
        system,
        units,
        n,
        fps,
    )
    assert rec.skeleton.up == "z" and np.isfinite(rec.positions).all()
    _, chosen, missing = best_set(rec.metadata["markers"])
    assert not missing and chosen["pelvis"] == ("LASI", "RASI", "LPSI", "RPSI")
    assert chosen["l_wrist"] == ("LWRA", "LWRB")
    lh, rh = rec.skeleton.index("l_hip"), rec.skeleton.index("r_hip")
    width = np.median(np.linalg.norm(rec.positions[:, lh] - rec.positions[:, rh], axis=1))
    assert 0.1 < width * (1e-3 if units == "mm" else 1) < 0.3  # metres between hip centres


def test_a_second_system_cuts_five_tennis_serves(c3d_dir, tmp_path, capsys):
    """OptiTrack, 21.8 s: standing, five serves, standing. The cut detector (defaults) marks
    the start and the end of the serving (a cut within 1 s of the hands' first and last
    movement), none in the stillness around it; the cuts go back into the file as events
    (Motive writes an EVENT group holding USED = 0 alone)."""
    path = c3d_dir / "optitrack_tennis_serve.c3d"
    rec = read(path)
    names = rec.skeleton.names
    hands = rec.positions[:, [names.index("l_wrist"), names.index("r_wrist")]]
    hands = hands - rec.positions[:, [names.index("pelvis")]]
    speed = np.linalg.norm(np.diff(hands, axis=0), axis=2).max(axis=1) * rec.fps
    moving = np.flatnonzero(speed > 0.5)  # m/s
    onset, offset = moving[0] / rec.fps, moving[-1] / rec.fps
    out = tmp_path / "serve_cuts.c3d"
    assert main(["segment", str(path), "--json", "--write-events", str(out)]) == 0
    res = json.loads(capsys.readouterr().out)
    cuts = np.asarray(res["cuts"]) / rec.fps
    assert len(cuts) >= 2
    assert np.abs(cuts - onset).min() <= 1.0 and np.abs(cuts - offset).min() <= 1.0
    assert onset - 1.0 <= cuts.min() and cuts.max() <= offset + 1.0
    events = read_events(out)
    assert [round(e["time"] * rec.fps) for e in events] == res["cuts"]
    assert res["events_written"] == len(events)


def test_labelled_segments_of_a_vicon_take_become_action_events(c3d_dir, tmp_path, capsys):
    out = tmp_path / "stairs_aca.c3d"
    src = c3d_dir / "vicon_pig_stairs.c3d"
    assert main(["segment", str(src), "--method", "aca", "--json", "--write-events", str(out)]) == 0
    res = json.loads(capsys.readouterr().out)
    events = read_events(out)
    assert [e["label"] for e in events] == [f"Action {s['label']}" for s in res["segments"]]
    first = 694  # the capture's frame number of the file's first frame (Nexus)
    assert [round(e["time"] * 120) - first for e in events] == [s["start"] for s in res["segments"]]


@pytest.mark.parametrize(
    "name,mset", [("qualisys_isb.c3d", "qualisys-isb"), ("qualisys_sports.c3d", "qualisys-sports")]
)
def test_qualisys_sets(c3d_dir, name, mset):
    rec = read(c3d_dir / name)
    assert rec.metadata["marker_set"] == mset and rec.metadata["manufacturer"] == "Qualisys"
    assert rec.fps == 200.0 and rec.skeleton.up == "z"
    assert np.isfinite(rec.positions).all()
    # joint centres: the knee between the femoral epicondyles, the hips inside the pelvis
    pel, lh, rh = (rec.skeleton.index(j) for j in ("pelvis", "l_hip", "r_hip"))
    width = np.linalg.norm(rec.positions[:, lh] - rec.positions[:, rh], axis=1)
    assert 100 < np.median(width) < 300  # mm: the distance between hip centres


def test_a_c3d_of_joints_reads_by_their_names(data_dir, tmp_path):
    """A C3D of a skeleton's joints (what inertial suits and solvers export), here CMU 86_01's
    ASF joints written by ezc3d: named as the ASF names them, the same cuts as the AMC."""
    import ezc3d

    amc = read(data_dir / "cmu86" / "86_01.amc.gz", skeleton=data_dir / "cmu86" / "86.asf")
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [amc.fps]
    c["parameters"]["POINT"]["LABELS"]["value"] = list(amc.skeleton.names)
    pts = np.ones((4, amc.skeleton.n_joints, amc.n_frames))
    pts[:3] = np.transpose(amc.positions, (2, 1, 0))
    c["data"]["points"] = pts
    path = tmp_path / "86_01_joints.c3d"
    c.write(str(path))
    rec = read(path)
    assert "marker_set" not in rec.metadata and rec.skeleton.up == amc.skeleton.up == "y"
    np.testing.assert_allclose(rec.positions, amc.positions, atol=1e-4)
    assert cuts_s(rec) == cuts_s(amc)


def test_a_set_no_map_names_is_refused_with_the_missing_markers(c3d_dir, capsys):
    assert main(["segment", str(c3d_dir / "optotrak.c3d")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "54 markers (Marker_1, Marker_2" in err
    assert "l_knee (LKNE)" in err and "pelvis (" in err


def test_segment_writes_its_cuts_as_c3d_events(c3d_dir, tmp_path, capsys):
    out = tmp_path / "01_01_events.c3d"
    assert (
        main(["segment", str(c3d_dir / "cmu_01_01.c3d"), "--json", "--write-events", str(out)]) == 0
    )
    res = json.loads(capsys.readouterr().out)
    events = read_events(out)
    assert res["events_written"] == len(events) == len(res["cuts"]) > 0
    first = 39  # the capture's frame number of the file's first frame (0-based)
    frames = [round(e["time"] * res["fps"]) - first for e in events]
    assert frames == res["cuts"]
    assert {e["label"] for e in events} == {"Cut"} and {e["context"] for e in events} == {"General"}
    assert read(out).positions.shape == read(c3d_dir / "cmu_01_01.c3d").positions.shape


def test_labelled_segments_become_action_events(c3d_dir, tmp_path):
    src = c3d_dir / "qualisys_isb.c3d"
    out = tmp_path / "q.c3d"
    segs = [{"start": 0, "end": 120, "label": 0}, {"start": 120, "end": 340, "label": 3}]
    assert write_events(src, out, segs, 200.0, method="aca") == 2
    before = read_events(src)
    assert [e["label"] for e in before] == ["LHS", "RTO", "RHS", "LTO", "LHS", "RTO", "RHS"]
    everything = read_events(out)
    assert everything[:7] == [{**e, "context": "General"} for e in before]  # kept
    ev = everything[7:]
    assert [e["label"] for e in ev] == ["Action 0", "Action 3"]
    assert [round(e["time"] * 200) - 704 for e in ev] == [0, 120]
    assert "frames 120-340" in ev[1]["description"]


def test_write_events_refuses_before_the_work(c3d_dir, data_dir, tmp_path, capsys):
    amc = data_dir / "cmu86" / "86_01.amc.gz"
    assert (
        main(
            [
                "segment",
                str(amc),
                "--skeleton",
                str(data_dir / "cmu86" / "86.asf"),
                "--write-events",
                str(tmp_path / "x.c3d"),
            ]
        )
        == 2
    )
    assert "needs a .c3d input" in capsys.readouterr().err


def test_truncated_c3d_keeps_the_frames_it_has(c3d_dir, tmp_path):
    data = (c3d_dir / "cmu_01_01.c3d").read_bytes()
    cut = tmp_path / "cut.c3d"
    cut.write_bytes(data[: len(data) * 2 // 3])
    with pytest.raises((TruncatedRecordingError, RecordingError)):
        read(cut)
    rec = read(cut, lenient=True)
    assert 1000 < rec.n_frames < 2751
    assert "the file was cut off" in rec.metadata["warnings"][0]


def test_cut_off_is_judged_by_the_bytes_against_every_count_the_file_gives(c3d_dir, tmp_path):
    """The Optotrak file says 1149 frames in its header and in POINT:FRAMES, and its data
    section holds 29 (ezc3d rewrites its own copy of both to 29): truly cut off. A header
    that alone overstates, with POINT:FRAMES and the bytes agreeing, is not."""
    import struct

    from streamseg.io.c3d import _frames_in_file

    opto = c3d_dir / "optotrak.c3d"
    assert _frames_in_file(opto) == (1149, 29)
    with pytest.raises(RecordingError, match="54 markers"):  # kept, then refused for its set
        read(opto, lenient=True)
    with pytest.raises(TruncatedRecordingError, match="29 readable frames of the 1149"):
        read(opto)
    data = bytearray((c3d_dir / "qualisys_isb.c3d").read_bytes())
    assert _frames_in_file(c3d_dir / "qualisys_isb.c3d") == (340, 340)
    first, last = struct.unpack("<HH", data[6:10])
    data[8:10] = struct.pack("<H", last + 500)  # the header alone says 500 frames more
    over = tmp_path / "over.c3d"
    over.write_bytes(bytes(data))
    assert _frames_in_file(over) == (340, 340)
    rec = read(over)
    assert rec.n_frames == 340 and not rec.metadata["warnings"]
    data[8:10] = struct.pack("<H", last)
    cut = tmp_path / "cut.c3d"
    cut.write_bytes(bytes(data[: len(data) - 200_000]))
    announced, held = _frames_in_file(cut)
    assert announced == 340 and 0 < held < 340
    rec = read(cut, lenient=True)
    assert rec.n_frames <= held and "the file was cut off" in rec.metadata["warnings"][0]


@pytest.mark.daemon
@pytest.mark.parametrize(
    "name",
    ["cmu_01_01.c3d", "qualisys_isb.c3d", "vicon_pig_stairs.c3d", "optitrack_tennis_serve.c3d"],
)
def test_c3d_replayed_into_the_daemon_gives_the_cuts_of_segment_online(
    name, c3d_dir, start_daemon, capsys, tmp_path
):
    """A Vicon and a Qualisys C3D through `replay` (with dropouts cut into a copy: short
    ones filled, a long one skipped, the same way live as in the file): the daemon's cuts are
    `segment --online`'s on the file, and the skipped gap is a gap event."""
    from streamseg.client import listen, subscribe
    from streamseg.commands.replay import replay
    from streamseg.io import write_npz

    rec = read(c3d_dir / name)
    pos = rec.positions.copy()
    n = rec.n_frames
    pos[n // 3 : n // 3 + 4, 5] = np.nan  # the left elbow lost for a few frames: filled
    pos[n // 2 : n // 2 + int(0.4 * rec.fps)] = np.nan  # 0.4 s without the body: skipped
    holes = tmp_path / "holes.npz"
    from dataclasses import replace

    write_npz(holes, replace(rec, positions=pos, metadata={}))
    assert main(["segment", str(holes), "--online", "--json"]) == 0
    want = json.loads(capsys.readouterr().out)
    assert [(g["start"], g["end"]) for g in want["gaps"]] == [(n // 2, n // 2 + int(0.4 * rec.fps))]
    _, ep = start_daemon()
    sub = subscribe(ep["publish"], ep["control"], stream="c3d")
    replay(read(holes, gap_fill=0), ep["ingest"], stream="c3d", speed=0, batch=7)
    events = list(listen(sub, stream="c3d", until_end=True, timeout=60))
    assert [e.frame for e in events if e.type == "cut"] == want["cuts"]
    gaps = [(e.expected, e.got, e.filled) for e in events if e.type == "gap"]
    assert gaps == [(n // 2, n // 2 + int(0.4 * rec.fps), False)]
