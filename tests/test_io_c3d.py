"""C3D in (markers mapped to joints) and out (segments written as C3D events), on real files
of Vicon and Qualisys systems (data/sources, README there)."""

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
    amc = read(data_dir / "sources" / "cmu01" / "01_01.amc.gz",
               skeleton=data_dir / "sources" / "cmu01" / "01.asf")
    bvh = read(data_dir / "sources" / "bvh" / "cc_01_01.bvh.gz")
    a, b, c = cuts_s(amc), cuts_s(bvh), cuts_s(c3d)
    assert a and len(a) == len(b) == len(c)
    assert np.abs(np.subtract(a, c)).max() <= 0.25 and np.abs(np.subtract(a, b)).max() <= 0.25


def test_plug_in_gait_names_of_the_pelvis(c3d_dir):
    """The map takes LASI/RASI/LPSI/RPSI (Plug-in Gait) as it takes the CMU LFWT/RFWT/LBWT/RBWT:
    the same file with the pelvis markers renamed gives the same joints."""
    from streamseg.skeleton.marker_sets import best_set, joint_positions

    rec = read(c3d_dir / "cmu_01_01.c3d", gap_fill=0)
    labels = rec.metadata["markers"]
    renamed = [{"LFWT": "LASI", "RFWT": "RASI", "LBWT": "LPSI", "RBWT": "RPSI"}.get(x, x)
               for x in labels]
    import ezc3d

    c = ezc3d.c3d(str(c3d_dir / "cmu_01_01.c3d"))
    xyz = np.transpose(c["data"]["points"][:3], (2, 1, 0))
    _, chosen, missing = best_set(renamed)
    assert not missing and chosen["pelvis"] == ("LASI", "RASI", "LPSI", "RPSI")
    got = joint_positions(xyz, renamed, chosen)
    np.testing.assert_allclose(got, rec.positions, equal_nan=True)


@pytest.mark.parametrize("name,mset", [("qualisys_isb.c3d", "qualisys-isb"),
                                       ("qualisys_sports.c3d", "qualisys-sports")])
def test_qualisys_sets(c3d_dir, name, mset):
    rec = read(c3d_dir / name)
    assert rec.metadata["marker_set"] == mset and rec.metadata["manufacturer"] == "Qualisys"
    assert rec.fps == 200.0 and rec.skeleton.up == "z"
    assert np.isfinite(rec.positions).all()
    # joint centres: the knee between the femoral epicondyles, the hips inside the pelvis
    pel, lh, rh = (rec.skeleton.index(j) for j in ("pelvis", "l_hip", "r_hip"))
    width = np.linalg.norm(rec.positions[:, lh] - rec.positions[:, rh], axis=1)
    assert 100 < np.median(width) < 300  # mm: the distance between hip centres


def test_a_set_no_map_names_is_refused_with_the_missing_markers(c3d_dir, capsys):
    assert main(["segment", str(c3d_dir / "optotrak.c3d")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "54 markers (Marker_1, Marker_2" in err
    assert "l_knee (LKNE)" in err and "pelvis (" in err


def test_segment_writes_its_cuts_as_c3d_events(c3d_dir, tmp_path, capsys):
    out = tmp_path / "01_01_events.c3d"
    assert main(["segment", str(c3d_dir / "cmu_01_01.c3d"), "--json",
                 "--write-events", str(out)]) == 0
    res = json.loads(capsys.readouterr().out)
    events = read_events(out)
    assert res["events_written"] == len(events) == len(res["cuts"]) > 0
    first = 39  # the capture's frame number of the file's first frame (0-based)
    frames = [round(e["time"] * res["fps"]) - first for e in events]
    assert frames == res["cuts"]
    assert {e["label"] for e in events} == {"Cut"} and {e["context"] for e in events} == {
        "General"}
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
    assert main(["segment", str(amc), "--skeleton", str(data_dir / "cmu86" / "86.asf"),
                 "--write-events", str(tmp_path / "x.c3d")]) == 2
    assert "needs a .c3d input" in capsys.readouterr().err


def test_truncated_c3d_keeps_the_frames_it_has(c3d_dir, tmp_path):
    data = (c3d_dir / "cmu_01_01.c3d").read_bytes()
    cut = tmp_path / "cut.c3d"
    cut.write_bytes(data[:len(data) * 2 // 3])
    with pytest.raises((TruncatedRecordingError, RecordingError)):
        read(cut)
    rec = read(cut, lenient=True)
    assert 1000 < rec.n_frames < 2751
    assert "the file was cut off" in rec.metadata["warnings"][0]


@pytest.mark.daemon
@pytest.mark.parametrize("name", ["cmu_01_01.c3d", "qualisys_isb.c3d"])
def test_c3d_replayed_into_the_daemon_gives_the_cuts_of_segment_online(
        name, c3d_dir, start_daemon, capsys, tmp_path):
    """A Vicon and a Qualisys C3D through `replay` (with dropouts cut into a copy: short
    ones filled, a long one skipped, the same way live as in the file): the daemon's cuts are
    `segment --online`'s on the file, and the skipped gap is a gap event."""
    from streamseg.client import listen, subscribe
    from streamseg.commands.replay import replay
    from streamseg.io import write_npz

    rec = read(c3d_dir / name)
    pos = rec.positions.copy()
    n = rec.n_frames
    pos[n // 3:n // 3 + 4, 5] = np.nan  # the left elbow lost for a few frames: filled
    pos[n // 2:n // 2 + int(0.4 * rec.fps)] = np.nan  # 0.4 s without the body: skipped
    holes = tmp_path / "holes.npz"
    from dataclasses import replace

    write_npz(holes, replace(rec, positions=pos, metadata={}))
    assert main(["segment", str(holes), "--online", "--json"]) == 0
    want = json.loads(capsys.readouterr().out)
    assert [(g["start"], g["end"]) for g in want["gaps"]] == [(n // 2, n // 2 +
                                                               int(0.4 * rec.fps))]
    _, ep = start_daemon()
    sub = subscribe(ep["publish"], ep["control"], stream="c3d")
    replay(read(holes, gap_fill=0), ep["ingest"], stream="c3d", speed=0, batch=7)
    events = list(listen(sub, stream="c3d", until_end=True, timeout=60))
    assert [e.frame for e in events if e.type == "cut"] == want["cuts"]
    gaps = [(e.expected, e.got, e.filled) for e in events if e.type == "gap"]
    assert gaps == [(n // 2, n // 2 + int(0.4 * rec.fps), False)]
