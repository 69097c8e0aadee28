"""Joint positions as input: CSV with joint names, .npy/.npz arrays, --joints for Kinect,
BlazePose, COCO-17 and BODY_25; real recordings of data/sources/keraal, blazepose and aist
(README there)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.config import LOFConfig
from streamseg.exceptions import RecordingError, SkeletonError
from streamseg.io import read
from streamseg.offline.lof import position_features
from streamseg.offline.lof_report import lof_report
from streamseg.skeleton.joint_sets import BODY25, JOINT_SETS, complete
from streamseg.skeleton.names import POINTS, resolve

EXERCISES = ("ctk", "elk", "rtk")


def cuts_of(rec, up=None) -> list[int]:
    cfg = LOFConfig()
    feats = position_features(rec.positions, rec.skeleton, rec.fps, cfg, up)
    return lof_report(feats, rec.fps, cfg, False)["cuts"]


def concat(recs):
    """Three exercises back to back: (recording, the two joins)."""
    from streamseg.recording import Recording

    pos = np.concatenate([r.positions for r in recs])
    joins = np.cumsum([r.n_frames for r in recs])[:-1].tolist()
    return Recording(recs[0].fps, recs[0].skeleton, pos, source="3 Keraal exercises"), joins


def test_an_asf_take_exported_as_positions_gives_the_cuts_of_the_take(rec, tmp_path, capsys):
    """86_01's joint positions as a CSV with its ASF joint names (any case), as an .npz with
    a names array: the same cuts as the AMC itself."""
    csv = tmp_path / "86_01.csv"
    names = [n.upper() if i % 2 else n for i, n in enumerate(rec.skeleton.names)]
    header = ",".join(f"{n}_{a}" for n in names for a in "XYZ")
    rows = rec.positions.reshape(rec.n_frames, -1)
    times = np.arange(rec.n_frames) / rec.fps
    with open(csv, "w") as fh:
        fh.write("time," + header + "\n")
        for t, r in zip(times, rows):
            fh.write(f"{float(t)!r}," + ",".join(repr(float(v)) for v in r) + "\n")
    npz = tmp_path / "86_01_pos.npz"
    np.savez(npz, positions=rec.positions, joint_names=np.array(rec.skeleton.names), fps=rec.fps)
    want = cuts_of(rec)
    for path in (csv, npz):
        got = read(path)
        assert got.fps == pytest.approx(120.0) and got.n_frames == rec.n_frames
        assert cuts_of(got) == want
    assert main(["segment", str(csv), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["cuts"] == want


def test_unnamed_positions_need_joints_and_say_so(rec, tmp_path, capsys):
    csv = tmp_path / "take.csv"
    np.savetxt(csv, rec.positions[:200].reshape(200, -1), delimiter=",")
    assert main(["segment", str(csv), "--fps", "120"]) == 2  # a 93-column matrix: features?
    err = capsys.readouterr().err
    assert "93 columns" in err or "columns" in err
    npy = tmp_path / "take.npy"
    np.save(npy, rec.positions[:500])
    assert main(["segment", str(npy), "--fps", "120"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "500x31x3 numbers without joint names" in err and "--joints" in err
    assert "Config" not in err and "_s" not in err.split("--joints")[0][-3:]
    npy33 = tmp_path / "pose.npy"
    np.save(npy33, np.zeros((10, 33, 3)))
    with pytest.raises(RecordingError, match="give --joints blazepose"):
        read(npy33, fps=30)


@pytest.mark.parametrize(
    "kind,pattern,joints",
    [
        ("kinect", "kinect_{}.csv", "kinect"),
        ("blazepose", "blazepose_{}.npy", "blazepose"),
        ("coco17", "alphapose_coco17_{}.npy", "coco17"),
        ("openpose", "openpose_coco18_{}.csv", None),
    ],
)
def test_real_keypoint_recordings_segment(data_dir, kind, pattern, joints, capsys):
    folder = data_dir / "sources" / "keraal"
    recs = [read(folder / pattern.format(e), fps=30, joints=joints) for e in EXERCISES]
    for r in recs:
        assert r.n_frames > 180 and np.isfinite(r.positions[:, :3]).any()
    take, joins = concat(recs)
    up = None if joints else "-y"  # image keypoints: y grows downwards
    found = cuts_of(take, up)
    assert found
    if kind in ("kinect", "blazepose"):  # each join between two exercises is found
        assert all(min(abs(c - j) for c in found) <= 30 for j in joins), (found, joins)
    args = ["segment", str(folder / pattern.format("ctk")), "--fps", "30", "--json"]
    if joints:
        args += ["--joints", joints]
    assert main(args) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["n_frames"] == recs[0].n_frames and "gaps" in res


def test_openpose_keypoints_it_did_not_find_are_gaps(data_dir):
    rec = read(data_dir / "sources" / "keraal" / "openpose_coco18_rtk.csv", fps=30)
    assert rec.metadata["filled_frames"] > 0  # joints missing in a few frames: filled
    assert (41, 74) in [tuple(g) for g in rec.metadata["gaps"]]  # a knee lost for 1.1 s


def test_blazepose_world_landmarks_are_what_the_joint_set_says(data_dir, capsys):
    """Real pose_world_landmarks (MediaPipe Pose on Pose2Sim's demo video, data/sources
    README): metres about the hips' centre with y down, as --joints blazepose declares
    (up -y), so a take reads without --up and its limbs have their size in metres."""
    from streamseg.skeleton.bones import upright_axis

    path = data_dir / "sources" / "blazepose" / "pose2sim_balance_world.npy"
    rec = read(path, joints="blazepose", fps=60)
    assert rec.skeleton.units == "m" and rec.skeleton.up == "-y"
    assert upright_axis(rec.positions, rec.skeleton) == "-y"  # the body stands along -y
    pelvis = rec.positions[:, rec.skeleton.index("pelvis")]  # the hips' midpoint
    assert np.abs(pelvis).max() < 0.01
    hip, knee = rec.skeleton.index("left_hip"), rec.skeleton.index("left_knee")
    thigh = np.median(np.linalg.norm(rec.positions[:, hip] - rec.positions[:, knee], axis=1))
    assert 0.3 < thigh < 0.6
    assert main(["segment", str(path), "--joints", "blazepose", "--fps", "60", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n_frames"] == 100


def test_coco17_keypoints_in_3d_of_a_dance(data_dir, capsys):
    """AIST++ COCO-17 keypoints triangulated from nine cameras (centimetres, world frame with
    y up, 60 Hz): 11.7 s of one basic break-dance move repeated, then standing. COCO
    keypoints come in any frame, so the up axis is the body's (y here, where image keypoints
    give -y); the one repeated move is not cut (checked by eye on a plot of wrists and
    ankles), a cut is allowed only where the dancer stops."""
    path = data_dir / "sources" / "aist" / "gBR_sBM_cAll_d04_mBR0_ch03_coco17.npy"
    rec = read(path, joints="coco17", fps=60)
    assert rec.skeleton.up == "y" and rec.n_frames == 720
    names = rec.skeleton.names
    hands = rec.positions[:, [names.index("left_wrist"), names.index("right_wrist")]]
    hands = hands - rec.positions[:, [names.index("pelvis")]]
    speed = np.linalg.norm(np.diff(hands, axis=0), axis=2).max(axis=1) * rec.fps / 100  # m/s
    stop = np.flatnonzero(speed > 0.5)[-1]
    assert main(["segment", str(path), "--joints", "coco17", "--fps", "60", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert all(abs(c - stop) <= rec.fps for c in res["cuts"]), (res["cuts"], stop)


def test_every_joint_set_reaches_the_canonical_points():
    for js in JOINT_SETS.values():
        names, _ = complete(js.names, np.zeros((1, len(js.names), 3)))
        assert len(set(resolve(names, tuple(POINTS), POINTS))) == len(POINTS)
    names, _ = complete(BODY25.names, np.zeros((1, 25, 3)))
    assert "pelvis" not in names and "spine" in names  # MidHip is the pelvis


def test_virtual_trunk_points_of_a_pose_model():
    names = JOINT_SETS["coco17"].names
    pos = np.zeros((2, 17, 3))
    pos[:, 11] = [1, 0, 0]  # left hip
    pos[:, 12] = [-1, 0, 0]  # right hip
    pos[:, 5] = [1, 2, 0]  # left shoulder
    pos[:, 6] = [-1, 2, 0]  # right shoulder
    out_names, out = complete(names, pos)
    assert out_names[17:] == ("pelvis", "neck", "sternum", "spine")
    np.testing.assert_allclose(out[0, 17:], [[0, 0, 0], [0, 2, 0], [0, 2, 0], [0, 1, 0]])


def test_unknown_skeleton_lists_what_is_missing():
    with pytest.raises(SkeletonError) as info:
        resolve(["Root", "Torso", "ArmL", "ArmR"], ("pelvis", "l_elbow"), POINTS)
    msg = str(info.value)
    assert "l_elbow (any of" in msg and "Its joints: Root, Torso, ArmL, ArmR" in msg
    assert "formats.md" in msg


def test_image_space_pose_says_what_it_assumed(data_dir, tmp_path):
    """Phone-camera pose (RepCount-A, data/repcount_pose): MediaPipe landmarks normalised per
    frame are recognised as such; the same as 2-D pixel keypoints with a frame where no
    person was found ((0, 0) everywhere) read as image coordinates, that frame a gap."""
    path = data_dir / "repcount_pose" / "poses" / "stu1_27.npy"
    rec = read(path, joints="blazepose", fps=30)
    assert rec.skeleton.units == "normalised image" and rec.skeleton.up == "-y"
    assert any("normalised per frame" in w for w in rec.metadata["warnings"])
    px = np.load(path)[:, :, :2] * np.array([320.0, 400.0]) + np.array([160.0, 40.0])
    px[5] = 0.0
    two = tmp_path / "pixels.npy"
    np.save(two, px)
    rec2 = read(two, joints="blazepose", fps=30)
    assert rec2.skeleton.units == "image" and rec2.n_frames == rec.n_frames
    warned = " ".join(rec2.metadata["warnings"])
    assert "2-D keypoints: taken as image coordinates" in warned
    assert "1 of 300 frames have no keypoint" in warned
    assert rec2.metadata["filled_frames"] > 0 and np.isfinite(rec2.positions[5]).all()
    raw = read(two, joints="blazepose", fps=30, gap_fill=0)
    assert np.isnan(raw.positions[5]).all() and np.isfinite(np.delete(raw.positions, 5, 0)).all()
    assert (np.delete(raw.positions, 5, 0)[:, :, 2] == 0).all()  # depth 0 in the image plane
