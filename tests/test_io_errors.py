"""Every reader error names the file, the line, what it found and what it expected."""

from __future__ import annotations

import gzip

import numpy as np
import pytest

from streamseg.exceptions import RecordingError, TruncatedRecordingError
from streamseg.io import read


@pytest.fixture(scope="module")
def amc_lines(data_dir):
    text = gzip.decompress((data_dir / "cmu86/86_01.amc.gz").read_bytes()).decode("latin-1")
    return text.replace("\r\n", "\n").split("\n")[: 3 + 30 * 4]  # header + 4 frames


@pytest.fixture
def asf(data_dir):
    return data_dir / "cmu86/86.asf"


def write(tmp_path, lines, name="bad.amc"):
    f = tmp_path / name
    f.write_text("\n".join(lines) + "\n", encoding="latin-1")
    return f


def test_truncated_last_frame_reported_and_lenient_keeps_good_frames(tmp_path, amc_lines, asf):
    lines = amc_lines[:-10]  # the 4th frame loses its last 10 bone lines
    f = write(tmp_path, lines)
    with pytest.raises(TruncatedRecordingError) as info:
        read(f, skeleton=asf)
    msg = str(info.value)
    assert str(f) in msg and "truncated last frame" in msg and "3 good frame(s)" in msg
    assert info.value.partial.n_frames == 3
    rec = read(f, skeleton=asf, lenient=True)
    full = read(write(tmp_path, amc_lines, "good.amc"), skeleton=asf)
    assert rec.n_frames == 3
    np.testing.assert_array_equal(rec.positions, full.positions[:3])
    assert rec.metadata["warnings"]


def test_truncated_mid_line(tmp_path, amc_lines, asf):
    lines = amc_lines[:-1] + ["ltoes"]  # file cut inside the last value line
    f = write(tmp_path, lines)
    with pytest.raises(TruncatedRecordingError) as info:
        read(f, skeleton=asf)
    assert f"{f}:{3 + 30 * 4}" in str(info.value)
    assert read(f, skeleton=asf, lenient=True).n_frames == 3


def test_unknown_bone(tmp_path, amc_lines, asf):
    lines = list(amc_lines)
    lines[3 + 30 + 5] = "lowerspine 1 2 3"  # 2nd frame, 5th bone line (file line 39)
    f = write(tmp_path, lines)
    with pytest.raises(RecordingError) as info:
        read(f, skeleton=asf)
    msg = str(info.value)
    assert f"{f}:{3 + 30 + 6}" in msg and "unknown bone 'lowerspine'" in msg
    assert "a bone of the skeleton" in msg
    assert not isinstance(info.value, TruncatedRecordingError)


def test_wrong_value_count(tmp_path, amc_lines, asf):
    lines = list(amc_lines)
    i = next(k for k in range(3 + 30, 3 + 60) if lines[k].startswith("lhumerus"))
    lines[i] = "lhumerus 1.0 2.0"
    f = write(tmp_path, lines)
    with pytest.raises(RecordingError) as info:
        read(f, skeleton=asf)
    msg = str(info.value)
    assert f"{f}:{i + 1}" in msg and "2 value(s) for lhumerus" in msg
    assert "3 value(s) (rx ry rz)" in msg


def test_non_numeric_value(tmp_path, amc_lines, asf):
    lines = list(amc_lines)
    lines[3 + 2] = "lowerback 1.0 abc 2.0"
    f = write(tmp_path, lines)
    with pytest.raises(RecordingError, match=r"bad.amc:6: found non-numeric value"):
        read(f, skeleton=asf)


def test_missing_skeleton(data_dir):
    with pytest.raises(
        RecordingError,
        match=r"86_01.amc.gz: found an AMC file without a skeleton"
        r".*--skeleton",
    ):
        read(data_dir / "cmu86/86_01.amc.gz")


def test_missing_skeleton_cli_message(data_dir, capsys):
    from streamseg.cli import main

    assert main(["segment", str(data_dir / "cmu86/86_01.amc.gz")]) == 2
    err = capsys.readouterr().err
    assert "--skeleton FILE.asf" in err
    # info describes the file all the same, and says what segmenting it needs
    assert main(["info", str(data_dir / "cmu86/86_01.amc.gz")]) == 0
    out = capsys.readouterr().out
    assert "frames:    4579" in out and "bones:     29 (root, lowerback" in out
    assert "segmenting: not as it stands" in out and "--skeleton FILE.asf" in out


@pytest.mark.parametrize("suffix", [".amc", ".bvh", ".npz", ".asf"])
def test_binary_junk(tmp_path, asf, suffix):
    f = tmp_path / f"junk{suffix}"
    f.write_bytes(bytes(range(256)) * 8)
    with pytest.raises(RecordingError) as info:
        read(f, skeleton=asf) if suffix != ".asf" else read(tmp_path / "x.amc.gz", skeleton=f)
    assert "junk" in str(info.value) or "x.amc.gz" in str(info.value)


def test_broken_gzip(tmp_path, data_dir, asf):
    raw = (data_dir / "cmu86/86_01.amc.gz").read_bytes()
    f = tmp_path / "cut.amc.gz"
    f.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(RecordingError, match="broken gzip"):
        read(f, skeleton=asf)


def test_unknown_suffix(tmp_path):
    f = tmp_path / "take.fbx"
    f.write_bytes(b"x")
    with pytest.raises(RecordingError, match=r"take.fbx: found suffix '.fbx'; expected one of"):
        read(f)


def test_garbage_c3d(tmp_path):
    pytest.importorskip("ezc3d")
    f = tmp_path / "take.c3d"
    f.write_bytes(b"x")
    with pytest.raises(RecordingError, match=r"take.c3d: found an unreadable C3D file"):
        read(f)


def test_missing_file(tmp_path):
    with pytest.raises(RecordingError, match="no such file"):
        read(tmp_path / "nope.bvh")


def test_asf_hierarchy_names_undefined_bone(tmp_path, asf, data_dir):
    text = asf.read_text(encoding="latin-1").replace("lhumerus lradius", "lhumerus lradiusX")
    f = tmp_path / "bad.asf"
    f.write_text(text)
    with pytest.raises(RecordingError, match="unknown bone 'lradiusX'"):
        read(data_dir / "cmu86/86_01.amc.gz", skeleton=f)


def test_asf_hierarchy_cycle_is_an_error_not_a_hang(tmp_path, asf, data_dir):
    text = asf.read_text(encoding="latin-1").replace(
        "    lhumerus lradius", "    lhumerus lradius\n    lradius lhumerus"
    )
    f = tmp_path / "cycle.asf"
    f.write_text(text)
    with pytest.raises(RecordingError, match="reached twice in :hierarchy"):
        read(data_dir / "cmu86/86_01.amc.gz", skeleton=f)


@pytest.mark.parametrize(
    "old,new,match",
    [
        ("length 0.45", "length 0", "length scale 0.0"),
        ("     name lfemur", "     name", "'name' without a value"),
    ],
)
def test_asf_bad_values(tmp_path, asf, data_dir, old, new, match):
    f = tmp_path / "bad.asf"
    f.write_text(asf.read_text(encoding="latin-1").replace(old, new, 1))
    with pytest.raises(RecordingError, match=match):
        read(data_dir / "cmu86/86_01.amc.gz", skeleton=f)


@pytest.mark.parametrize(
    "old,new", [("Frames: 2", "Frames: nan"), ("Frame Time: 0.033333", "Frame Time: nan")]
)
def test_bvh_non_finite_header(tmp_path, old, new):
    from pathlib import Path

    src = Path(__file__).parent / "data" / "cmu_like.bvh"
    f = tmp_path / "bad.bvh"
    f.write_text(src.read_text().replace(old, new))
    with pytest.raises(RecordingError, match="Frame Time"):
        read(f)
