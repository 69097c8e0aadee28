"""Joint-name map: skeletons from ASF, BVH rigs, Kinect, pose models and C3D reach one vocabulary.

Two vocabularies, because formats place joints differently:

* *points* (:data:`POINTS`): where a joint is. ASF joints sit at the END of their bone
  (ASF ``lhumerus`` is the elbow), BVH and Kinect joints at the START (BVH ``LeftForeArm`` is
  the elbow).
* *rotating segments* (:data:`SEGMENTS`): whose rotation a joint's frame carries (ASF
  ``lhumerus`` and BVH ``LeftArm`` both rotate the upper arm).
"""

from __future__ import annotations

from streamseg.exceptions import SkeletonError

# canonical point -> candidate names: CMU/HDM05 ASF; BVH (CMU MotionBuilder conversions,
# Mixamo, Truebones; DAZ/Poser/Second Life "hip, lShldr"; Character Creator "CC_Base_L_Thigh"
# and 3ds Max Biped "Bip01 L Thigh" after their prefix); Kinect v2; BlazePose and COCO
# ("left_shoulder"); OpenPose BODY_25 ("LShoulder"). Order matters: the first present wins.
POINTS = {
    "pelvis": ("root", "Hips", "hip", "SpineBase", "pelvis", "MidHip", "Pelvis"),
    "spine": ("lowerback", "Spine", "SpineMid", "spine", "Spine1", "abdomen", "Waist", "Spine01"),
    "l_shoulder": (
        "lclavicle",
        "LeftArm",
        "ShoulderLeft",
        "l_shoulder",
        "LeftUpperArm",
        "left_shoulder",
        "LShoulder",
        "lShldr",
        "L_Upperarm",
        "L UpperArm",
    ),
    "l_elbow": (
        "lhumerus",
        "LeftForeArm",
        "ElbowLeft",
        "l_elbow",
        "LeftLowerArm",
        "left_elbow",
        "LElbow",
        "lForeArm",
        "L_Forearm",
        "L Forearm",
    ),
    "l_wrist": (
        "lradius",
        "LeftHand",
        "WristLeft",
        "l_wrist",
        "left_wrist",
        "LWrist",
        "lHand",
        "L_Hand",
        "L Hand",
    ),
    "r_shoulder": (
        "rclavicle",
        "RightArm",
        "ShoulderRight",
        "r_shoulder",
        "RightUpperArm",
        "right_shoulder",
        "RShoulder",
        "rShldr",
        "R_Upperarm",
        "R UpperArm",
    ),
    "r_elbow": (
        "rhumerus",
        "RightForeArm",
        "ElbowRight",
        "r_elbow",
        "RightLowerArm",
        "right_elbow",
        "RElbow",
        "rForeArm",
        "R_Forearm",
        "R Forearm",
    ),
    "r_wrist": (
        "rradius",
        "RightHand",
        "WristRight",
        "r_wrist",
        "right_wrist",
        "RWrist",
        "rHand",
        "R_Hand",
        "R Hand",
    ),
    "l_hip": (
        "lhipjoint",
        "LeftUpLeg",
        "HipLeft",
        "l_hip",
        "LeftUpperLeg",
        "left_hip",
        "LHip",
        "lThigh",
        "L_Thigh",
        "L Thigh",
    ),
    "l_knee": (
        "lfemur",
        "LeftLeg",
        "KneeLeft",
        "l_knee",
        "LeftLowerLeg",
        "left_knee",
        "LKnee",
        "lShin",
        "L_Calf",
        "L Calf",
    ),
    "l_ankle": (
        "ltibia",
        "LeftFoot",
        "AnkleLeft",
        "l_ankle",
        "left_ankle",
        "LAnkle",
        "lFoot",
        "L_Foot",
        "L Foot",
    ),
    "r_hip": (
        "rhipjoint",
        "RightUpLeg",
        "HipRight",
        "r_hip",
        "RightUpperLeg",
        "right_hip",
        "RHip",
        "rThigh",
        "R_Thigh",
        "R Thigh",
    ),
    "r_knee": (
        "rfemur",
        "RightLeg",
        "KneeRight",
        "r_knee",
        "RightLowerLeg",
        "right_knee",
        "RKnee",
        "rShin",
        "R_Calf",
        "R Calf",
    ),
    "r_ankle": (
        "rtibia",
        "RightFoot",
        "AnkleRight",
        "r_ankle",
        "right_ankle",
        "RAnkle",
        "rFoot",
        "R_Foot",
        "R Foot",
    ),
    "neck": ("lowerneck", "Neck", "SpineShoulder", "neck", "NeckTwist01", "Neck1"),
    "sternum": (
        "thorax",
        "SpineShoulder",
        "Neck",
        "sternum",
        "chest",
        "Spine2",
        "Spine02",
        "Chest",
    ),
}

#: Prefixes rigs put before every joint name, matched case-insensitively after a namespace
#: (``Subject:``, ``mixamorig:``) is removed: Mixamo without colon, Character Creator, Biped.
RIG_PREFIXES = ("mixamorig", "cc_base_", "bip001 ", "bip01 ", "bip001_", "bip01_")


def bare(name: str) -> str:
    """``name`` without a namespace (``"Vicon:LFHD"`` -> ``"LFHD"``) or rig prefix
    (``"mixamorig:LeftArm"``, ``"mixamorig1LeftArm"``, ``"CC_Base_L_Thigh"``, ``"Bip01 L
    Thigh"``)."""
    name = name.rsplit(":", 1)[-1]
    low = name.lower()
    for p in RIG_PREFIXES:
        if low.startswith(p):
            rest = name[len(p) :]
            if p == "mixamorig":
                rest = rest.lstrip("0123456789")
            return rest or name
    return name


# canonical rotating segment -> candidate joint names whose rotation it is (ASF, BVH rigs as
# in POINTS)
SEGMENTS = {
    "lower_back": ("lowerback", "LowerBack", "Spine", "abdomen", "Waist"),
    "upper_back": ("upperback", "Spine", "Spine1", "Spine01", "abdomen2"),
    "thorax": ("thorax", "Spine1", "Spine2", "Chest", "chest", "Spine02"),
    "neck": ("lowerneck", "Neck", "neck", "NeckTwist01"),
    "l_clavicle": ("lclavicle", "LeftShoulder", "lCollar", "L_Clavicle", "L Clavicle"),
    "l_upper_arm": ("lhumerus", "LeftArm", "lShldr", "L_Upperarm", "L UpperArm"),
    "l_forearm": ("lradius", "LeftForeArm", "lForeArm", "L_Forearm", "L Forearm"),
    "r_clavicle": ("rclavicle", "RightShoulder", "rCollar", "R_Clavicle", "R Clavicle"),
    "r_upper_arm": ("rhumerus", "RightArm", "rShldr", "R_Upperarm", "R UpperArm"),
    "r_forearm": ("rradius", "RightForeArm", "rForeArm", "R_Forearm", "R Forearm"),
    "l_thigh": ("lfemur", "LeftUpLeg", "lThigh", "L_Thigh", "L Thigh"),
    "l_shin": ("ltibia", "LeftLeg", "lShin", "L_Calf", "L Calf"),
    "r_thigh": ("rfemur", "RightUpLeg", "rThigh", "R_Thigh", "R Thigh"),
    "r_shin": ("rtibia", "RightLeg", "rShin", "R_Calf", "R Calf"),
}


def resolve(names, wanted, table: dict) -> list[int]:
    """Indices in ``names`` of the canonical joints ``wanted``, through ``table``.

    Exact matches are preferred over case-insensitive ones, and those over names matched
    without their namespace or rig prefix (:func:`bare`). The first candidate present wins, and a
    joint index is never used twice (BVH ``Spine`` may serve ``spine`` or ``upper_back``).

    Raises
    ------
    SkeletonError
        Listing every canonical joint that no name of the skeleton matches.
    """
    names = list(names)
    lower = {n.lower(): i for i, n in reversed(list(enumerate(names)))}
    plain = {bare(n).lower(): i for i, n in reversed(list(enumerate(names)))}
    out, missing, used = [], [], set()
    for canon in wanted:
        exact = [names.index(c) for c in table[canon] if c in names]
        loose = [lower[c.lower()] for c in table[canon] if c.lower() in lower]
        prefixed = [plain[c.lower()] for c in table[canon] if c.lower() in plain]
        idx = next((j for j in exact + loose + prefixed if j not in used), None)
        if idx is None:
            missing.append(f"{canon} (any of {', '.join(table[canon])})")
        else:
            used.add(idx)
            out.append(idx)
    if missing:
        raise SkeletonError(
            "skeleton lacks joints the features need: "
            + "; ".join(missing)
            + f". Its joints: {', '.join(names)}. Rename them to one of the names listed "
            "(docs/guide/formats.md lists the skeletons streamseg knows)"
        )
    return out
