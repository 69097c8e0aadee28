"""Sources: the same take in three formats, and markerless keypoints of three exercises.

Usage: python benchmarks/sources_agreement.py

Table 1: CMU 01_01 (data/sources) as Vicon C3D markers (Plug-in Gait map), as the solved
ASF/AMC and as a BVH on a Character Creator rig: the cuts of the live detector's decisions
(offline, defaults), in seconds.

Table 2: the Keraal takes of one participant (exercises CTK, ELK, RTK, ~6.5 s each, 30 Hz)
joined back to back, per sensor (Kinect v2, BlazePose, AlphaPose COCO-17 and OpenPose COCO-18
keypoints): the cuts, the two joins, and how far the nearest cut is from each join. The joins
are abrupt, not natural transitions (a concatenation, as data/README.md describes).

Table 3: every whole take of another system in data/sources (C3D, TRC, 3-D keypoints), as read by
``streamseg.io.read``: system, marker set or names, length, and the cuts (defaults), in seconds.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from _common import DATA

from streamseg.config import LOFConfig
from streamseg.io import read
from streamseg.offline.lof import position_features
from streamseg.offline.lof_report import lof_report

SRC = DATA / "sources"


def cuts(positions, skeleton, fps, up=None) -> list[int]:
    cfg = LOFConfig()
    feats = position_features(positions, skeleton, fps, cfg, up)
    return lof_report(feats, fps, cfg, False)["cuts"]


def formats() -> None:
    takes = [
        ("C3D markers (Vicon, plug-in-gait)", read(SRC / "c3d/cmu_01_01.c3d")),
        ("ASF/AMC (CMU solve)", read(SRC / "cmu01/01_01.amc.gz", skeleton=SRC / "cmu01/01.asf")),
        ("BVH (Character Creator rig)", read(SRC / "bvh/cc_01_01.bvh.gz")),
    ]
    print(f"{'CMU 01_01 as':<36}{'fps':>6}{'frames':>8}  cuts (s)")
    for name, rec in takes:
        found = cuts(rec.positions, rec.skeleton, rec.fps)
        print(
            f"{name:<36}{rec.fps:>6.0f}{rec.n_frames:>8}  "
            f"{', '.join(f'{c / rec.fps:.2f}' for c in found)}"
        )


def keypoints() -> None:
    kinds = [
        ("Kinect v2 (25 joints)", "kinect_{}.csv", "kinect", None),
        ("BlazePose (33 landmarks)", "blazepose_{}.npy", "blazepose", None),
        ("AlphaPose COCO-17 (2-D)", "alphapose_coco17_{}.npy", "coco17", None),
        ("OpenPose COCO-18 (2-D, header)", "openpose_coco18_{}.csv", None, "-y"),
    ]
    print(f"{'sensor':<32}{'frames':>7}  {'joins':<10} {'cuts':<28} nearest cut to each join")
    for name, pattern, joints, up in kinds:
        recs = [
            read(SRC / "keraal" / pattern.format(e), fps=30, joints=joints)
            for e in ("ctk", "elk", "rtk")
        ]
        pos = np.concatenate([r.positions for r in recs])
        joins = np.cumsum([r.n_frames for r in recs])[:-1]
        found = cuts(pos, recs[0].skeleton, 30.0, up)
        near = [min(abs(c - j) for c in found) / 30 if found else float("nan") for j in joins]
        print(
            f"{name:<32}{pos.shape[0]:>7}  {', '.join(map(str, joins)):<10} "
            f"{', '.join(map(str, found)):<28} {', '.join(f'{d:.2f} s' for d in near)}"
        )


def systems() -> None:
    takes = [
        ("c3d/vicon_pig_stairs.c3d", "Vicon Nexus", {}),
        ("c3d/optitrack_tennis_serve.c3d", "OptiTrack Motive", {}),
        ("c3d/qualisys_isb.c3d", "Qualisys", {}),
        ("c3d/qualisys_sports.c3d", "Qualisys", {}),
        ("trc/opencap_walk.trc", "OpenCap (OpenPose 3-D)", {}),
        (
            "aist/gBR_sBM_cAll_d04_mBR0_ch03_coco17.npy",
            "AIST++ (COCO-17 3-D)",
            {"joints": "coco17", "fps": 60},
        ),
        (
            "blazepose/pose2sim_balance_world.npy",
            "MediaPipe world",
            {"joints": "blazepose", "fps": 60},
        ),
    ]
    print(f"{'take':<42}{'system':<24}{'named by':<16}{'fps':>5}{'s':>7}  cuts (s)")
    for path, system, kw in takes:
        rec = read(SRC / path, **kw)
        found = cuts(rec.positions, rec.skeleton, rec.fps)
        named = rec.metadata.get("marker_set", kw.get("joints", "joint names"))
        print(
            f"{Path(path).name:<42}{system:<24}{named:<16}"
            f"{rec.fps:>5.0f}{rec.n_frames / rec.fps:>7.1f}  "
            f"{', '.join(f'{c / rec.fps:.2f}' for c in found) or '-'}"
        )


def main() -> None:
    formats()
    print()
    keypoints()
    print()
    systems()


if __name__ == "__main__":
    main()
