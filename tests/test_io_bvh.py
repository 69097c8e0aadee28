"""BVH reading: a small hand-written CMU-conversion-style file with hand-derived positions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from streamseg.exceptions import RecordingError, TruncatedRecordingError
from streamseg.io import read
from streamseg.skeleton import bone_angles

BVH = Path(__file__).parent / "data" / "cmu_like.bvh"


@pytest.fixture(scope="module")
def rec():
    return read(BVH)


def test_header(rec):
    assert rec.n_frames == 2
    assert rec.fps == pytest.approx(30.0, rel=1e-4)
    assert rec.skeleton.names[0] == "Hips"
    assert "LeftHand_End" in rec.skeleton.names


def test_rest_frame_positions_are_summed_offsets(rec):
    names = rec.skeleton.names
    p = rec.positions[0]
    # chain Hips(1,95,2) -> Spine1 (0,24,0) -> LeftShoulder (3,18,0) -> LeftArm (15,0,0) ...
    np.testing.assert_allclose(p[names.index("LeftArm")], [1 + 18, 95 + 42, 2])
    np.testing.assert_allclose(p[names.index("LeftHand")], [1 + 71, 95 + 42, 2])
    np.testing.assert_allclose(p[names.index("LeftFoot")], [1 + 10, 95 - 92, 2])


def test_rotated_frame_by_hand(rec):
    """Frame 2: Hips Yrotation 90 maps body (x, y, z) to world (z, y, -x); LeftForeArm
    Zrotation 90 turns the forearm (25, 0, 0) to (0, 25, 0) in body axes."""
    names = rec.skeleton.names
    p = rec.positions[1]
    np.testing.assert_allclose(p[names.index("LeftForeArm")], [1, 95 + 42, 2 - 46], atol=1e-9)
    np.testing.assert_allclose(p[names.index("LeftHand")], [1, 95 + 67, 2 - 46], atol=1e-9)


def test_bone_angles_through_name_map(rec):
    a = bone_angles(rec.positions, rec.skeleton, inclinations=False)
    assert a[0, 4] == pytest.approx(0.0, abs=1e-7)  # straight left elbow
    assert a[1, 4] == pytest.approx(np.pi / 2, abs=1e-9)  # bent 90 degrees
    assert a[1, 5] == pytest.approx(0.0, abs=1e-7)  # right elbow untouched


def test_truncated_motion_line(tmp_path):
    text = BVH.read_text()
    f = tmp_path / "cut.bvh"
    f.write_text(text.rstrip()[:-20])
    with pytest.raises(TruncatedRecordingError, match=r"cut.bvh:\d+: found \d+ values in frame 1"):
        read(f)
    assert read(f, lenient=True).n_frames == 1


def test_bad_channels_line(tmp_path):
    f = tmp_path / "bad.bvh"
    f.write_text(BVH.read_text().replace("CHANNELS 3 Zrotation", "CHANNELS 3 Wrotation", 1))
    with pytest.raises(RecordingError, match=r"bad.bvh:12: found .*CHANNELS 3 Wrotation"):
        read(f)
