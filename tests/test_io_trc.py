"""TRC marker files (OpenSim's format): a real OpenCap take of OpenPose BODY_25 keypoints
triangulated in 3-D (data/sources/trc, README there), and the Plug-in Gait markers of a real
C3D written as a TRC."""

from __future__ import annotations

import json

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.exceptions import RecordingError, TruncatedRecordingError
from streamseg.io import read
from streamseg.skeleton.names import POINTS, resolve


@pytest.fixture(scope="module")
def walk(data_dir):
    return data_dir / "sources" / "trc" / "opencap_walk.trc"


def write_trc(path, names, xyz, rate, units="mm"):
    """OpenSim's layout: five header lines, then frame, time, x y z per point (tabs)."""
    n = xyz.shape[0]
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{path.name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\t"
        "OrigDataStartFrame\tOrigNumFrames",
        f"{rate}\t{rate}\t{n}\t{len(names)}\t{units}\t{rate}\t1\t{n}",
        "Frame#\tTime\t" + "\t\t\t".join(names) + "\t\t",
        "\t\t" + "\t".join(f"{a}{i + 1}" for i in range(len(names)) for a in "XYZ"),
        "",
    ]
    for f in range(n):
        cells = ["" if np.isnan(v) else f"{v:.5f}" for v in xyz[f].ravel()]
        lines.append(f"{f + 1}\t{f / rate:.5f}\t" + "\t".join(cells))
    path.write_text("\n".join(lines) + "\n")


def test_opencap_keypoints_in_3d_segment(walk, capsys):
    """OpenCap: OpenPose BODY_25 keypoints from two phones triangulated (metres, y up), with
    the anatomical markers OpenCap adds: the keypoints' names reach the features' points."""
    rec = read(walk)
    assert (rec.n_frames, rec.fps, rec.skeleton.units, rec.skeleton.up) == (222, 60.0, "m", "y")
    assert rec.metadata["format"] == "trc" and "marker_set" not in rec.metadata
    idx = resolve(rec.skeleton.names, tuple(POINTS), POINTS)
    assert [rec.skeleton.names[i] for i in idx[:4]] == ["midHip", "spine", "LShoulder", "LElbow"]
    assert np.isfinite(rec.positions).all()
    assert main(["segment", str(walk), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["n_frames"] == 222 and res["segments"][-1]["end"] == 222


def test_plug_in_gait_markers_as_trc_give_the_c3d_joints(data_dir, tmp_path):
    pytest.importorskip("ezc3d")
    import ezc3d

    src = data_dir / "sources" / "c3d" / "vicon_pig_stairs.c3d"
    c3d = read(src, gap_fill=0)
    c = ezc3d.c3d(str(src))
    xyz = np.transpose(c["data"]["points"][:3], (2, 1, 0))
    names = c3d.metadata["markers"]
    xyz[40:43, names.index("LKNE")] = np.nan  # blank cells: a gap the reader fills
    path = tmp_path / "stairs.trc"
    write_trc(path, names, xyz, 120.0)
    rec = read(path)
    assert rec.metadata["marker_set"] == "plug-in-gait" and rec.skeleton.up == "z"
    assert rec.metadata["filled_frames"] == 3
    keep = np.ones(rec.n_frames, bool)
    keep[40:43] = False
    np.testing.assert_allclose(rec.positions[keep], c3d.positions[keep], atol=1e-4)


def test_a_cut_off_trc_keeps_its_whole_frames(walk, tmp_path, capsys):
    text = walk.read_text()
    cut = tmp_path / "cut.trc"
    cut.write_text(text[: len(text) - 3000])
    with pytest.raises(TruncatedRecordingError):
        read(cut)
    assert main(["segment", str(cut), "--json"]) == 0
    out, err = capsys.readouterr()
    res = json.loads(out)
    assert 200 < res["n_frames"] < 222 and "the file was cut off" in err


def test_points_nothing_names_are_refused_with_what_is_missing(tmp_path, capsys):
    path = tmp_path / "odd.trc"
    write_trc(path, ["A1", "A2", "A3"], np.zeros((20, 3, 3)), 100.0)
    with pytest.raises(RecordingError, match="closest: plug-in-gait"):
        read(path)
    assert main(["segment", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "l_knee (LKNE)" in err and "joint names" in err


def test_a_row_without_its_trailing_points_has_them_as_gaps(walk, tmp_path):
    lines = walk.read_text().split("\n")
    lines[10] = "\t".join(lines[10].split("\t")[:-6])  # row 5 lacks its last two points
    path = tmp_path / "short.trc"
    path.write_text("\n".join(lines))
    rec = read(path, gap_fill=0)
    names = rec.metadata["markers"]
    assert rec.n_frames == 222 and not rec.metadata["warnings"]
    last = rec.skeleton.index(names[-1])
    assert np.isnan(rec.positions[4, last]).all() and np.isfinite(rec.positions[5, last]).all()


def test_a_gzip_compressed_trc_reads_as_the_plain_one(walk, tmp_path):
    """``.trc.gz`` (how marker takes are archived) gives the frames of the plain file."""
    import gzip

    gz = tmp_path / "walk.trc.gz"
    gz.write_bytes(gzip.compress(walk.read_bytes()))
    plain, packed = read(walk), read(gz)
    assert packed.fps == plain.fps
    np.testing.assert_array_equal(packed.positions, plain.positions)
