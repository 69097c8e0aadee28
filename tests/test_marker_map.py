"""``--markers MAP.toml``: a marker set of the user's own, for markers no built-in set maps;
and ``streamseg info`` on a file that cannot be segmented as it stands."""

from __future__ import annotations

import json

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.exceptions import ParameterError
from streamseg.skeleton.marker_map import load_marker_map
from streamseg.skeleton.marker_sets import JOINTS

pytest.importorskip("ezc3d")

# one or two markers per joint of the Qualisys sports set (qualisys_sports.c3d)
MAP = {
    "pelvis": ["LASIS", "RASIS"],
    "spine": ["T10"],
    "sternum": ["Sternum"],
    "neck": ["C7"],
    "l_shoulder": ["LAcromium"],
    "l_elbow": ["LElbowLat"],
    "l_wrist": ["LWristLat", "LWristMed"],
    "r_shoulder": ["RAcromium"],
    "r_elbow": ["RElbowLat"],
    "r_wrist": ["RWristLat", "RWristMed"],
    "l_hip": ["LASIS"],
    "l_knee": ["LKneeLat"],
    "l_ankle": ["LAnkleLat"],
    "r_hip": ["RASIS"],
    "r_knee": ["RKneeLat"],
    "r_ankle": ["RAnkleLat"],
}


def _toml(path, mapping, rename=None):
    rename = rename or {}
    path.write_text(
        "".join(
            f"{j} = {json.dumps([rename.get(m, m) for m in ms])}\n" for j, ms in mapping.items()
        )
    )
    return path


@pytest.fixture(scope="module")
def renamed(tmp_path_factory, data_dir):
    """qualisys_sports.c3d's markers as a TRC with the names ``Marker_1...`` no set maps:
    ``(trc path, marker names of the original, xyz (n, n_markers, 3))``."""
    from pathlib import Path

    from streamseg.io.c3d import _open, c3d_info

    c, _ = _open(Path(data_dir / "sources" / "c3d" / "qualisys_sports.c3d"))
    info = c3d_info(c)
    pts = np.asarray(c["data"]["points"], dtype=np.float64)
    labels = info["labels"][: pts.shape[1]]
    xyz = np.transpose(pts[:3], (2, 1, 0))
    m = xyz.shape[1]
    folder = tmp_path_factory.mktemp("trc")
    for stem, names in (("renamed", [f"Marker_{i + 1}" for i in range(m)]), ("named", labels)):
        _write_trc(folder / f"{stem}.trc", names, xyz, info["rate"])
    return folder / "renamed.trc", labels, xyz


def _write_trc(path, names, xyz, rate):
    """A TRC of markers ``names`` (mm; an empty cell where NaN)."""
    n, m = xyz.shape[:2]
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{path.name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits",
        f"{rate:g}\t{rate:g}\t{n}\t{m}\tmm",
        "Frame#\tTime\t" + "\t\t\t".join(names),
        "\t\t" + "\t".join(f"{a}{i + 1}" for i in range(m) for a in "XYZ"),
        "",
    ]
    for f in range(n):
        lines.append(
            f"{f + 1}\t{f / rate:.5f}\t"
            + "\t".join("" if not np.isfinite(v) else repr(float(v)) for v in xyz[f].ravel())
        )
    path.write_text("\n".join(lines) + "\n")


def test_a_map_makes_each_joint_the_mean_of_its_markers(renamed, tmp_path):
    from streamseg.io import read

    path, labels, xyz = renamed
    to_new = {lab: f"Marker_{i + 1}" for i, lab in enumerate(labels)}
    rec = read(path, markers=_toml(tmp_path / "map.toml", MAP, to_new))
    assert rec.skeleton.names == JOINTS and rec.metadata["marker_set"].endswith("(--markers)")
    for j, joint in enumerate(JOINTS):
        cols = [labels.index(m) for m in MAP[joint]]
        want = xyz[:, cols].mean(axis=1)
        ok = np.isfinite(want).all(axis=1)
        np.testing.assert_allclose(rec.positions[ok, j], want[ok], err_msg=joint)


def test_segment_and_info_with_and_without_the_map(renamed, tmp_path, capsys):
    path, labels, _ = renamed
    to_new = {lab: f"Marker_{i + 1}" for i, lab in enumerate(labels)}
    # without a map: segment refuses in one line that names --markers; info describes it
    assert main(["segment", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--markers MAP.toml" in err[0]
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"markers:   {len(labels)} (Marker_1, Marker_2" in out
    assert "segmenting: not as it stands" in out and 'pelvis = ["?"]' in out
    # with the map: the renamed file segments as the original names through the same map
    mine = _toml(tmp_path / "mine.toml", MAP, to_new)
    assert main(["segment", str(path), "--markers", str(mine), "--json"]) == 0
    got = json.loads(capsys.readouterr().out.splitlines()[-1])
    named = path.parent / "named.trc"
    assert (
        main(
            ["segment", str(named), "--markers", str(_toml(tmp_path / "orig.toml", MAP)), "--json"]
        )
        == 0
    )
    want = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert got["n_frames"] == want["n_frames"] == 80
    assert got["cuts"] == want["cuts"] and got["segments"] == want["segments"]


@pytest.mark.parametrize(
    "text, said",
    [
        ("knee = 'LKNE'\n", "knee is not a joint of the map"),
        ("pelvis = 'LASI'\n", "no markers for spine, sternum"),
        (
            "".join(f"{j} = 'M'\n" for j in JOINTS).replace("neck = 'M'", "neck = 3"),
            "neck = 3: expected a marker name",
        ),
        ("pelvis = [", "not valid TOML"),
        ("clusters = [['A', 'B']]\n", "four marker names or more"),
        ("pairs = [['A', 'B']]\n", "two left/right pairs of one segment"),
    ],
)
def test_a_bad_map_is_one_line_naming_the_fix(tmp_path, text, said):
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(ParameterError, match=said):
        load_marker_map(bad)


def test_a_map_naming_markers_the_file_lacks_says_which(renamed, tmp_path, capsys):
    path, _, _ = renamed
    assert main(["segment", str(path), "--markers", str(_toml(tmp_path / "m.toml", MAP))]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "without the markers" in err[0] and "pelvis (LASIS RASIS)" in err[0]


def test_a_maps_clusters_and_pairs_place_lost_markers(renamed, tmp_path):
    """A pelvis of four markers is a cluster without saying so: LASIS lost for a stretch is
    placed from the other three (the pelvis where the full markers put it); with ``pairs``,
    LASIS absent from the file altogether is RASIS mirrored across the mid-plane of the back
    pair, and the file reads (it was a NaN joint, or a refusal, before)."""
    from streamseg.io import read

    _, labels, xyz = renamed
    pelvis = ["LASIS", "RASIS", "LBackAsis", "RBackAsis"]
    mapping = {**MAP, "pelvis": pelvis}
    cols = [labels.index(m) for m in pelvis]
    truth = xyz[:, cols].mean(axis=1)
    seen = np.isfinite(truth).all(axis=1)
    lost = xyz.copy()
    a = xyz.shape[0] // 3
    lost[a : 2 * a, labels.index("LASIS")] = np.nan
    path = tmp_path / "lost.trc"
    _write_trc(path, labels, lost, 100.0)
    rec = read(path, markers=_toml(tmp_path / "map.toml", mapping))
    p = rec.positions[:, JOINTS.index("pelvis")]
    assert np.isfinite(p[a : 2 * a][seen[a : 2 * a]]).all()
    ok = seen[a : 2 * a]
    err = np.linalg.norm(p[a : 2 * a][ok] - truth[a : 2 * a][ok], axis=1)
    assert np.median(err) < 3.0 and err.max() < 5.0, (np.median(err), err.max())  # mm: 1.8, 2.6

    keep = [i for i, m in enumerate(labels) if m != "LASIS"]
    path = tmp_path / "absent.trc"
    _write_trc(path, [labels[i] for i in keep], xyz[:, keep], 100.0)
    text = "".join(f"{j} = {json.dumps(ms)}\n" for j, ms in mapping.items())
    pairs = [[["LASIS", "RASIS"], ["LBackAsis", "RBackAsis"]]]
    (tmp_path / "pairs.toml").write_text(f"pairs = {json.dumps(pairs)}\n" + text)
    rec = read(path, markers=tmp_path / "pairs.toml")
    p = rec.positions[:, JOINTS.index("pelvis")]
    assert np.isfinite(p[seen]).all()
    err = np.linalg.norm(p[seen] - truth[seen], axis=1)
    assert np.median(err) < 15.0, np.median(err)  # mm, 9.6: a mirror image, not the marker
    assert any("LASIS" in w and "mirrored" in w for w in rec.metadata["warnings"])


def test_a_live_stream_places_lost_markers_from_the_past_alone(renamed):
    """The live placement (:class:`LiveMarkerFill`, the daemon's and the LSL input's): LASIS
    lost for a third of the take is carried by the rigid motion of the other pelvis markers
    from the last frame it was seen with them, in any packet size; never seen, it is RASIS
    mirrored (the offline reader also blends the first frame after a loss: 1.8 mm median)."""
    from streamseg.skeleton.marker_fill import LiveMarkerFill, live_layout
    from streamseg.skeleton.marker_sets import MarkerSet

    _, labels, xyz = renamed
    pelvis = ["LASIS", "RASIS", "LBackAsis", "RBackAsis"]
    mset = MarkerSet(
        "map", "", {}, clusters=(tuple(pelvis),), pairs=((tuple(pelvis[:2]), tuple(pelvis[2:])),)
    )
    layout = live_layout(mset, labels)
    cols = [labels.index(m) for m in pelvis]
    truth = xyz[:, cols].mean(axis=1)
    seen = np.isfinite(truth).all(axis=1)

    def live(frames, step):
        fill, out, notes = LiveMarkerFill(layout), [], []
        for i in range(0, frames.shape[0], step):
            placed, said = fill.fill(frames[i : i + step])
            out.append(placed)
            notes += said
        return np.concatenate(out)[:, cols].mean(axis=1), notes

    lost = xyz.copy()
    a = xyz.shape[0] // 3
    lost[a : 2 * a, labels.index("LASIS")] = np.nan
    p, notes = live(lost, 1)
    for step in (7, 40, xyz.shape[0]):
        np.testing.assert_array_equal(live(lost, step)[0], p)
    assert notes == [
        "marker LASIS lost: placed from the markers of its segment (RASIS LBackAsis RBackAsis)"
    ]
    ok = seen[a : 2 * a]
    err = np.linalg.norm(p[a : 2 * a][ok] - truth[a : 2 * a][ok], axis=1)
    assert np.median(err) < 5.0 and err.max() < 6.0, (np.median(err), err.max())  # 3.6, 4.6

    gone = xyz.copy()
    gone[:, labels.index("LASIS")] = np.nan
    p, notes = live(gone, 10)
    err = np.linalg.norm(p[seen] - truth[seen], axis=1)
    assert np.median(err) < 15.0, np.median(err)  # mm, 9.6 (as offline)
    assert len(notes) == 1 and "RASIS mirrored" in notes[0]
    # once seen, a marker is not mirrored again: lost then, it is placed from the cluster
    back = gone.copy()
    back[40:50, labels.index("LASIS")] = xyz[40:50, labels.index("LASIS")]
    after = np.arange(xyz.shape[0]) >= 50
    mirrored = np.linalg.norm(live(gone, 10)[0] - truth, axis=1)[seen & after]
    p, notes = live(back, 10)
    err = np.linalg.norm(p - truth, axis=1)[seen & after]
    assert np.isfinite(err).all() and np.median(err) < 0.5 * np.median(mirrored), (
        np.median(err),
        np.median(mirrored),
    )
    assert len(notes) == 1  # one note a marker


def test_a_live_stream_without_a_pairs_marker_gets_it_mirrored(renamed, tmp_path):
    """As the reader does for a file: a pair's marker absent from the stream's names is added
    (lost in every frame) so that the map applies, and mirrored from its twin."""
    from streamseg.skeleton.marker_fill import LiveMarkerFill, live_layout
    from streamseg.skeleton.marker_map import joints_of_markers, marker_columns, stream_markers

    _, labels, xyz = renamed
    pelvis = ["LASIS", "RASIS", "LBackAsis", "RBackAsis"]
    text = "".join(f"{j} = {json.dumps(ms)}\n" for j, ms in {**MAP, "pelvis": pelvis}.items())
    (tmp_path / "pairs.toml").write_text(
        f"pairs = {json.dumps([[pelvis[:2], pelvis[2:]]])}\n" + text
    )
    mset = load_marker_map(tmp_path / "pairs.toml")
    keep = [i for i, m in enumerate(labels) if m != "LASIS"]
    names = [labels[i] for i in keep]
    assert stream_markers(mset, names) == (*names, "LASIS")
    columns, missing = marker_columns(mset, names)
    assert not missing
    fill = LiveMarkerFill(live_layout(mset, stream_markers(mset, names)))
    placed, notes = fill.fill(xyz[:, keep])
    p = joints_of_markers(placed, columns)[:, JOINTS.index("pelvis")]
    truth = xyz[:, [labels.index(m) for m in pelvis]].mean(axis=1)
    seen = np.isfinite(truth).all(axis=1)
    err = np.linalg.norm(p[seen] - truth[seen], axis=1)
    assert np.median(err) < 15.0 and len(notes) == 1 and "mirrored" in notes[0]
    # without pairs in the map the stream lacks the pelvis (the daemon's `skeleton` error)
    (tmp_path / "plain.toml").write_text(text)
    assert marker_columns(load_marker_map(tmp_path / "plain.toml"), names)[0] is None
