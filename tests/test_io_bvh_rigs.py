"""BVH from the wild: rigs whose joint names carry a prefix or another convention (real
Character Creator conversions of CMU takes, data/sources/bvh; Mixamo, Biped, DAZ names)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.exceptions import SkeletonError
from streamseg.io import read
from streamseg.skeleton.bones import BONES, bone_angles, bone_point_indices
from streamseg.skeleton.names import POINTS, SEGMENTS, bare, resolve


def test_character_creator_rig_gives_the_angles_of_the_amc(data_dir):
    """CMU 02_01 (walk) as a BVH on a Character Creator rig (60 Hz) and as the AMC (120 Hz):
    the bone angles of the same instants agree (median difference < 0.1 rad)."""
    bvh = read(data_dir / "sources" / "bvh" / "cc_02_01.bvh.gz")
    amc = read(data_dir / "cmu02" / "02_01.amc.gz", skeleton=data_dir / "cmu02" / "02.asf")
    assert bvh.fps == pytest.approx(60, abs=0.01)
    names = [bvh.skeleton.names[i] for i in np.unique(bone_point_indices(bvh.skeleton))]
    assert "CC_Base_L_Thigh" in names and "CC_Base_R_Forearm" in names
    a = bone_angles(amc.positions[::2], amc.skeleton, inclinations=False)
    b = bone_angles(bvh.positions, bvh.skeleton, inclinations=False)
    n = min(a.shape[0], b.shape[0])
    diff = np.abs(a[:n] - b[:n])
    assert np.median(diff) < 0.1, np.median(diff, axis=0)


def test_a_real_bvh_segments(data_dir, capsys):
    path = data_dir / "sources" / "bvh" / "cc_01_01.bvh.gz"
    assert main(["segment", str(path), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["n_frames"] == 1376 and res["cuts"]
    assert main(["segment", str(path), "--method", "aca", "--json"]) == 0  # rotations too
    assert len(json.loads(capsys.readouterr().out)["segments"]) >= 1


@pytest.mark.parametrize(
    "names",
    [
        [
            f"mixamorig:{n}"
            for n in (
                "Hips",
                "Spine",
                "Spine1",
                "Spine2",
                "Neck",
                "LeftShoulder",
                "LeftArm",
                "LeftForeArm",
                "LeftHand",
                "RightShoulder",
                "RightArm",
                "RightForeArm",
                "RightHand",
                "LeftUpLeg",
                "LeftLeg",
                "LeftFoot",
                "RightUpLeg",
                "RightLeg",
                "RightFoot",
            )
        ],
        [
            f"Bip01 {n}"
            for n in (
                "Pelvis",
                "Spine",
                "Spine1",
                "Spine2",
                "Neck",
                "L Clavicle",
                "L UpperArm",
                "L Forearm",
                "L Hand",
                "R Clavicle",
                "R UpperArm",
                "R Forearm",
                "R Hand",
                "L Thigh",
                "L Calf",
                "L Foot",
                "R Thigh",
                "R Calf",
                "R Foot",
            )
        ],
        [
            "hip",
            "abdomen",
            "chest",
            "neck",
            "head",
            "lCollar",
            "lShldr",
            "lForeArm",
            "lHand",
            "rCollar",
            "rShldr",
            "rForeArm",
            "rHand",
            "lThigh",
            "lShin",
            "lFoot",
            "rThigh",
            "rShin",
            "rFoot",
        ],
    ],
)
def test_rig_conventions_reach_the_bones(names):
    points = tuple(dict.fromkeys(p for bone in BONES for p in bone))
    idx = resolve(names, points, POINTS)
    got = dict(zip(points, (bare(names[i]) for i in idx)))
    assert got["l_elbow"] in ("LeftForeArm", "L Forearm", "lForeArm")
    assert got["r_knee"] in ("RightLeg", "R Calf", "rShin")
    if "abdomen" not in names:  # DAZ has two spine joints, not the three ACA rotates
        resolve(names, tuple(SEGMENTS), SEGMENTS)  # the rotations of ACA's features too


def test_bare_names():
    assert bare("mixamorig1:LeftArm") == "LeftArm" and bare("mixamorig7LeftArm") == "LeftArm"
    assert bare("CC_Base_L_Thigh") == "L_Thigh" and bare("Subject01:LFHD") == "LFHD"
    assert bare("Bip001 L Calf") == "L Calf" and bare("Hips") == "Hips"


def test_an_unknown_rig_gets_the_list_of_what_is_missing(tmp_path, capsys):
    bvh = tmp_path / "robot.bvh"
    bvh.write_text(
        "HIERARCHY\nROOT Base\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition "
        "Zposition Zrotation Xrotation Yrotation\n JOINT Link1\n {\n  OFFSET 0 1 0\n"
        "  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 1 0"
        "\n  }\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0.01\n0 0 0 0 0 0 0 0 0\n"
        "0 0 0 0 0 0 0 0 0\n"
    )
    assert main(["segment", str(bvh)]) == 2
    err = capsys.readouterr().err
    assert "lacks joints the features need" in err and "l_elbow (any of" in err
    assert "Its joints: Base, Link1" in err
    with pytest.raises(SkeletonError):
        bone_point_indices(read(bvh).skeleton)
