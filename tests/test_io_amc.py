"""ASF/AMC reading and forward kinematics on real CMU and HDM05 files."""

from __future__ import annotations

import gzip
import math

import numpy as np
import pytest

from streamseg.io import read, read_amc, write_npz
from streamseg.io.asf import read_asf

INCH = 0.0254
SCALE = 0.45  # 86.asf `:units length 0.45`


def rx(a):
    c, s = math.cos(math.radians(a)), math.sin(math.radians(a))
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a):
    c, s = math.cos(math.radians(a)), math.sin(math.radians(a))
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rz(a):
    c, s = math.cos(math.radians(a)), math.sin(math.radians(a))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


@pytest.fixture(scope="module")
def cmu86(data_dir):
    return read(data_dir / "cmu86/86_01.amc.gz", skeleton=data_dir / "cmu86/86.asf")


def test_cmu86_shape_and_rate(cmu86):
    assert cmu86.n_frames == 4579
    assert cmu86.fps == 120.0
    assert cmu86.positions.shape == (4579, 31, 3)
    assert cmu86.rotations.shape == (4579, 31, 3, 3)
    assert cmu86.skeleton.names[0] == "root"


def test_cmu86_frame1_by_hand(cmu86):
    """Joint positions of AMC frame 1 derived by hand from the numbers in 86.asf / 86_01.amc.

    Acclaim: a bone's world rotation is R_parent C M C^-1 (C from `axis`, M from the frame's
    dof values, x applied first), its end point parent_end + R (direction * length); lengths
    and translations are inches / `length` scale, here converted to metres.
    """
    to_m = INCH / SCALE
    # frame 1: root 17.3866 18.0959 0.17894 -88.1261 -87.8338 101.641
    root_pos = np.array([17.3866, 18.0959, 0.17894]) * to_m
    r_root = rz(101.641) @ ry(-87.8338) @ rx(-88.1261)
    # lhipjoint: direction 0.561145 -0.797705 0.220866, length 2.46425, axis 0 0 0, no dof
    d_hip = np.array([0.561145, -0.797705, 0.220866])
    lhip = root_pos + r_root @ (d_hip / np.linalg.norm(d_hip) * 2.46425 * to_m)
    # lfemur: direction 0.34202 -0.939693 0, length 7.95556, axis 0 0 20 XYZ;
    # frame 1: lfemur -29.1974 1.82053 -23.3363 (rx ry rz)
    c = rz(20)
    m = rz(-23.3363) @ ry(1.82053) @ rx(-29.1974)
    d_fem = np.array([0.34202, -0.939693, 0.0])
    lknee = lhip + r_root @ c @ m @ c.T @ (d_fem / np.linalg.norm(d_fem) * 7.95556 * to_m)
    # lowerback: direction 0.00322089 0.999033 0.0438587, length 2.07568;
    # frame 1: lowerback -10.2994 0.514365 0.238228
    m_lb = rz(0.238228) @ ry(0.514365) @ rx(-10.2994)
    d_lb = np.array([0.00322089, 0.999033, 0.0438587])
    lowerback = root_pos + r_root @ m_lb @ (d_lb / np.linalg.norm(d_lb) * 2.07568 * to_m)

    names = cmu86.skeleton.names
    p = cmu86.positions[0]
    np.testing.assert_allclose(p[names.index("root")], root_pos, atol=1e-9)
    np.testing.assert_allclose(p[names.index("lhipjoint")], lhip, atol=1e-9)
    np.testing.assert_allclose(p[names.index("lfemur")], lknee, atol=1e-9)
    np.testing.assert_allclose(p[names.index("lowerback")], lowerback, atol=1e-9)


def test_bone_lengths_constant(cmu86):
    par = cmu86.skeleton.parents
    lengths = np.linalg.norm(cmu86.positions[:, 1:] - cmu86.positions[:, par[1:]], axis=2)
    rel = np.abs(lengths - lengths[0]) / np.maximum(lengths[0], 1e-12)
    assert rel.max() < 1e-6


def test_body_is_upright_and_human_sized(cmu86):
    names = cmu86.skeleton.names
    head = cmu86.positions[:, names.index("head")]
    # y is up in CMU data; a standing adult's head is 1.4-1.9 m above the floor
    assert 1.4 < np.median(head[:, 1]) < 1.9


@pytest.mark.parametrize("ending", [b"\r\n", b"\n", b"mixed"])
def test_line_endings(tmp_path, data_dir, ending):
    text = gzip.decompress((data_dir / "cmu86/86_01.amc.gz").read_bytes())
    lines = text.replace(b"\r\n", b"\n").split(b"\n")[: 3 + 30 * 5]
    if ending == b"mixed":
        body = b"".join(line + (b"\r\n" if i % 2 else b"\n") for i, line in enumerate(lines))
    else:
        body = ending.join(lines) + ending
    f = tmp_path / "x.amc"
    f.write_bytes(body)
    rec = read(f, skeleton=data_dir / "cmu86/86.asf")
    ref = read(data_dir / "cmu86/86_01.amc.gz", skeleton=data_dir / "cmu86/86.asf")
    assert rec.n_frames == 5
    np.testing.assert_allclose(rec.positions, ref.positions[:5])


def test_radians_header(tmp_path, data_dir):
    """The same frames in :RADIANS give the same pose."""
    text = gzip.decompress((data_dir / "cmu86/86_01.amc.gz").read_bytes()).decode("latin-1")
    lines = text.replace("\r\n", "\n").split("\n")[: 3 + 30 * 2]
    out = []
    for line in lines:
        words = line.split()
        if line.startswith(":DEGREES"):
            out.append(":RADIANS")
        elif line.startswith(("#", ":")):
            out.append(line)
        elif len(words) > 1 and words[0] != "root":
            out.append(" ".join([words[0]] + [repr(math.radians(float(w))) for w in words[1:]]))
        elif len(words) > 1:
            vals = words[1:4] + [repr(math.radians(float(w))) for w in words[4:]]
            out.append(" ".join(["root"] + vals))
        else:
            out.append(line)
    f = tmp_path / "rad.amc"
    f.write_text("\n".join(out))
    rec = read(f, skeleton=data_dir / "cmu86/86.asf")
    ref = read(data_dir / "cmu86/86_01.amc.gz", skeleton=data_dir / "cmu86/86.asf")
    np.testing.assert_allclose(rec.positions, ref.positions[:2], atol=1e-9)


def test_asf_length_scale(tmp_path, data_dir):
    """Halving `:units length` doubles every length and translation."""
    asf = (data_dir / "cmu86/86.asf").read_text(encoding="latin-1")
    f = tmp_path / "half.asf"
    f.write_text(asf.replace("length 0.45", "length 0.225", 1))
    assert read_asf(f).length_scale == 0.225
    a = read(data_dir / "cmu86/86_01.amc.gz", skeleton=data_dir / "cmu86/86.asf")
    b = read(data_dir / "cmu86/86_01.amc.gz", skeleton=f)
    np.testing.assert_allclose(b.positions[:10], 2 * a.positions[:10], atol=1e-12)


def test_hdm05_latin1_and_mixed_endings(data_dir):
    path = next((data_dir / "hdm05_reps/squat1Reps").glob("HDM_bd_*.amc.gz"))
    raw = gzip.decompress(path.read_bytes())
    assert any(b > 127 for b in raw[:200]), "fixture should hold a Latin-1 header byte"
    rec = read(path, skeleton=data_dir / "hdm05_reps/asf/HDM_bd.asf")
    assert rec.n_frames > 50
    assert np.isfinite(rec.positions).all()


def test_npz_round_trip_is_exact(tmp_path, cmu86):
    f = tmp_path / "86_01.npz"
    write_npz(f, cmu86)
    back = read(f)
    np.testing.assert_array_equal(back.positions, cmu86.positions)
    np.testing.assert_array_equal(back.rotations, cmu86.rotations)
    assert back.skeleton.names == cmu86.skeleton.names
    np.testing.assert_array_equal(back.skeleton.parents, cmu86.skeleton.parents)
    assert back.fps == cmu86.fps
    assert back.source == cmu86.source
    assert back.skeleton.up == cmu86.skeleton.up == "y"
    from dataclasses import replace

    write_npz(f, replace(cmu86, skeleton=replace(cmu86.skeleton, up="-z")))
    assert read(f).skeleton.up == "-z"


def test_explicit_fps(data_dir):
    rec = read_amc(data_dir / "cmu86/86_01.amc.gz", data_dir / "cmu86/86.asf", fps=60)
    assert rec.fps == 60 and rec.duration == pytest.approx(4579 / 60)


def test_compressed_npz_reads_eagerly(tmp_path, cmu86):
    f = tmp_path / "small.npz"
    write_npz(f, cmu86.slice(0, 50), compress=True)
    back = read(f)
    assert not isinstance(back.rotations, np.memmap)
    np.testing.assert_array_equal(back.rotations, cmu86.rotations[:50])
    np.testing.assert_array_equal(back.positions, cmu86.positions[:50])


def _body_and_layout(path, asf):
    """An AMC file's text from its first frame number on, and its bone layout."""
    from streamseg.io import amc
    from streamseg.io._text import read_text

    skel = read_asf(asf)
    lines = read_text(path).split("\n")
    first, _ = amc._header_end(lines)
    known = {b.name: len(b.dof) for b in skel.bones}
    layout = []
    for line in lines[first + 1 :]:
        words = line.split()
        if len(words) == 1 and words[0].isdigit():
            break
        if words and words[0] in known and words[0] not in dict(layout):
            layout.append((words[0], known[words[0]]))
    return "\n".join(lines[first:]).encode("latin-1"), layout, skel


@pytest.mark.parametrize(
    "take, asf",
    [
        ("cmu86/86_01.amc.gz", "cmu86/86.asf"),
        ("hdm05_reps/squat1Reps/HDM_bd_squat1Reps_001_120.amc.gz", "hdm05_reps/asf/HDM_bd.asf"),
    ],
)
def test_frame_kernel_and_pose_kernel_equal_their_naive_twins(data_dir, take, asf):
    """The one-pass parse gives the very doubles ``float`` gives; the pose kernel the numpy
    matrix products (to rounding: numpy's products are BLAS calls)."""
    from streamseg.io import amc
    from tests.naive import naive_acclaim_pose, naive_amc_values

    body, layout, skel = _body_and_layout(data_dir / take, data_dir / asf)
    values = amc._parse_fast(body, layout)
    np.testing.assert_array_equal(values, naive_amc_values(body, layout))
    pos, rot = amc.pose(skel, layout, values, skel.angle_unit)
    want_pos, want_rot = naive_acclaim_pose(skel, layout, values, skel.angle_unit)
    np.testing.assert_allclose(pos, want_pos, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rot, want_rot, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    "old, new",
    [
        (b" 17.3866 ", b" 1.73866e+001 "),  # an exponent
        (b" 17.3866 ", b" +17.38660 "),  # a sign, a trailing zero
        (b" 17.3866 ", b" 1.7386600000000001e1 "),  # 17 digits: float's own rounding
        (b" 17.3866 ", b" 1.73866e-30 "),  # beyond an exact power of ten
        (b" 17.3866 ", b" nan "),  # float reads it; the one-pass parse does not
        (b"\n2\n", b"\n+2\n"),  # a signed frame number
        (b" 17.3866 ", b"\t17.3866\xa0"),  # a Latin-1 no-break space
    ],
)
def test_every_spelling_of_a_number_reads_as_float_reads_it(tmp_path, data_dir, old, new):
    """Whether the one-pass parse takes a file or leaves it to the line-by-line reader, the
    frames are the numbers ``float`` reads."""
    from streamseg.io import amc
    from tests.naive import naive_amc_values

    raw = gzip.decompress((data_dir / "cmu86/86_01.amc.gz").read_bytes()).replace(b"\r\n", b"\n")
    head = b"\n".join(raw.split(b"\n")[: 3 + 30 * 3]) + b"\n"
    assert old in head
    changed = head.replace(old, new, 1)
    f = tmp_path / "x.amc"
    f.write_bytes(changed)
    body, layout, skel = _body_and_layout(f, data_dir / "cmu86/86.asf")
    want = naive_amc_values(body.replace(b"\xa0", b" "), layout)
    assert want is not None and want.shape == (3, 62)
    rec = read(f, skeleton=data_dir / "cmu86/86.asf")
    np.testing.assert_array_equal(
        rec.positions, amc.pose(skel, layout, want, skel.angle_unit)[0], strict=True
    )
