"""Joint-name map: skeletons from CMU/HDM05 ASF, BVH conversions and Kinect v2 reach one vocabulary.

Two vocabularies, because formats place joints differently:

* *points* (:data:`POINTS`): where a joint is. ASF joints sit at the END of their bone
  (ASF ``lhumerus`` is the elbow), BVH and Kinect joints at the START (BVH ``LeftForeArm`` is
  the elbow).
* *rotating segments* (:data:`SEGMENTS`): whose rotation a joint's frame carries (ASF
  ``lhumerus`` and BVH ``LeftArm`` both rotate the upper arm).
"""

from __future__ import annotations

from streamseg.exceptions import SkeletonError

# canonical point -> candidate names (ASF, BVH CMU conversions / Mixamo-like, Kinect v2)
POINTS = {
    "pelvis": ("root", "Hips", "hip", "SpineBase", "pelvis"),
    "spine": ("lowerback", "Spine", "SpineMid", "spine", "Spine1"),
    "l_shoulder": ("lclavicle", "LeftArm", "ShoulderLeft", "l_shoulder", "LeftUpperArm"),
    "l_elbow": ("lhumerus", "LeftForeArm", "ElbowLeft", "l_elbow", "LeftLowerArm"),
    "l_wrist": ("lradius", "LeftHand", "WristLeft", "l_wrist"),
    "r_shoulder": ("rclavicle", "RightArm", "ShoulderRight", "r_shoulder", "RightUpperArm"),
    "r_elbow": ("rhumerus", "RightForeArm", "ElbowRight", "r_elbow", "RightLowerArm"),
    "r_wrist": ("rradius", "RightHand", "WristRight", "r_wrist"),
    "l_hip": ("lhipjoint", "LeftUpLeg", "HipLeft", "l_hip", "LeftUpperLeg"),
    "l_knee": ("lfemur", "LeftLeg", "KneeLeft", "l_knee", "LeftLowerLeg"),
    "l_ankle": ("ltibia", "LeftFoot", "AnkleLeft", "l_ankle"),
    "r_hip": ("rhipjoint", "RightUpLeg", "HipRight", "r_hip", "RightUpperLeg"),
    "r_knee": ("rfemur", "RightLeg", "KneeRight", "r_knee", "RightLowerLeg"),
    "r_ankle": ("rtibia", "RightFoot", "AnkleRight", "r_ankle"),
    "neck": ("lowerneck", "Neck", "SpineShoulder", "neck"),
    "sternum": ("thorax", "SpineShoulder", "Neck", "sternum"),
}

# canonical rotating segment -> candidate joint names whose rotation it is (ASF, BVH)
SEGMENTS = {
    "lower_back": ("lowerback", "LowerBack", "Spine"),
    "upper_back": ("upperback", "Spine", "Spine1"),
    "thorax": ("thorax", "Spine1", "Spine2", "Chest"),
    "neck": ("lowerneck", "Neck"),
    "l_clavicle": ("lclavicle", "LeftShoulder"),
    "l_upper_arm": ("lhumerus", "LeftArm"),
    "l_forearm": ("lradius", "LeftForeArm"),
    "r_clavicle": ("rclavicle", "RightShoulder"),
    "r_upper_arm": ("rhumerus", "RightArm"),
    "r_forearm": ("rradius", "RightForeArm"),
    "l_thigh": ("lfemur", "LeftUpLeg"),
    "l_shin": ("ltibia", "LeftLeg"),
    "r_thigh": ("rfemur", "RightUpLeg"),
    "r_shin": ("rtibia", "RightLeg"),
}


def resolve(names, wanted, table: dict) -> list[int]:
    """Indices in ``names`` of the canonical joints ``wanted``, through ``table``.

    Exact matches are preferred over case-insensitive ones. The first candidate present wins, and a
    joint index is never used twice (BVH ``Spine`` may serve ``spine`` or ``upper_back``).

    Raises
    ------
    SkeletonError
        Listing every canonical joint that no name of the skeleton matches.
    """
    names = list(names)
    lower = {n.lower(): i for i, n in reversed(list(enumerate(names)))}
    out, missing, used = [], [], set()
    for canon in wanted:
        exact = [names.index(c) for c in table[canon] if c in names]
        loose = [lower[c.lower()] for c in table[canon] if c.lower() in lower]
        idx = next((j for j in exact + loose if j not in used), None)
        if idx is None:
            missing.append(f"{canon} (any of {', '.join(table[canon])})")
        else:
            used.add(idx)
            out.append(idx)
    if missing:
        raise SkeletonError(
            "skeleton lacks joints the features need: "
            + "; ".join(missing)
            + f". Its joints: {', '.join(names)}. Rename them or extend streamseg.skeleton.names."
        )
    return out
