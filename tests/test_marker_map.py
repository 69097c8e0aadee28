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
    n, m = xyz.shape[:2]
    folder = tmp_path_factory.mktemp("trc")
    for stem, names in (("renamed", [f"Marker_{i + 1}" for i in range(m)]), ("named", labels)):
        lines = [
            f"PathFileType\t4\t(X/Y/Z)\t{stem}.trc",
            "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits",
            f"{info['rate']:g}\t{info['rate']:g}\t{n}\t{m}\tmm",
            "Frame#\tTime\t" + "\t\t\t".join(names),
            "\t\t" + "\t".join(f"{a}{i + 1}" for i in range(m) for a in "XYZ"),
            "",
        ]
        for f in range(n):
            lines.append(
                f"{f + 1}\t{f / info['rate']:.5f}\t"
                + "\t".join(repr(float(v)) for v in xyz[f].ravel())
            )
        (folder / f"{stem}.trc").write_text("\n".join(lines) + "\n")
    return folder / "renamed.trc", labels, xyz


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
