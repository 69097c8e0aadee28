"""The joints of an LSL motion-capture stream, from its XML description.

The XDF/LSL meta-data convention for motion capture describes one channel per coordinate::

    <desc><channels>
      <channel><label>LKNE_X</label><marker>LKNE</marker><type>PositionX</type>
               <unit>millimeters</unit></channel>
      ...
    </channels></desc>

A channel's joint is its ``marker`` (or ``joint``; else its label without an ``_X``-like
suffix), its axis its ``type`` (``PositionX/Y/Z``; else the label's suffix). Channels of other
types (``Conf``, ``Occluded``, orientations) are ignored. A joint needs all three axes.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass

from streamseg.exceptions import ParameterError

_SUFFIX = re.compile(r"^(.+?)[_.\- :]([xyz])$", re.IGNORECASE)
CONVENTION = (
    "one <channel> per coordinate in <desc><channels>, with <label>, <marker> (or "
    "<joint>) and <type> PositionX/PositionY/PositionZ (the XDF mocap meta-data)"
)


@dataclass(frozen=True)
class StreamSkeleton:
    """Joints of a stream: ``names``, ``columns[j]`` the channel indices of joint j's x, y,
    z, and the ``units`` of the first position channel."""

    names: tuple
    columns: tuple
    units: str


def _text(el, tag: str) -> str:
    child = el.find(tag)
    return (child.text or "").strip() if child is not None else ""


def describe(xml: str) -> dict:
    """``name``, ``type``, ``source_id``, ``channel_count``, ``nominal_srate`` of a stream's
    XML (``StreamInfo.as_xml()``)."""
    root = ET.fromstring(xml)
    return {
        "name": _text(root, "name"),
        "type": _text(root, "type"),
        "source_id": _text(root, "source_id"),
        "channel_count": int(_text(root, "channel_count") or 0),
        "nominal_srate": float(_text(root, "nominal_srate") or 0),
        "channel_format": _text(root, "channel_format"),
    }


def stream_skeleton(xml: str) -> StreamSkeleton:
    """The joints of a mocap stream's XML description.

    Raises
    ------
    ParameterError
        Naming the stream and what its description lacks (no channels; channels without a
        joint or an axis; joints without all three axes).
    """
    root = ET.fromstring(xml)
    info = describe(xml)
    who = (
        f"LSL stream {info['name']!r} (type {info['type'] or '?'}, source id "
        f"{info['source_id'] or 'none'})"
    )
    channels = root.findall("./desc/channels/channel")
    if not channels:
        raise ParameterError(
            f"{who} has no channel description: streamseg needs "
            f"{CONVENTION}; add them to the outlet's desc()"
        )
    if len(channels) != info["channel_count"]:
        raise ParameterError(
            f"{who} describes {len(channels)} channels but sends "
            f"{info['channel_count']}: the description must have one "
            "<channel> per channel, in order"
        )
    joints: dict = {}
    order: list = []
    units = ""
    unnamed = []
    for i, ch in enumerate(channels):
        label, kind = _text(ch, "label"), _text(ch, "type")
        joint = _text(ch, "marker") or _text(ch, "joint")
        is_position = kind.lower().startswith("position")
        axis = kind[-1].lower() if is_position and kind[-1:].lower() in ("x", "y", "z") else ""
        m = _SUFFIX.match(label)
        if kind and not kind.lower().startswith("position"):
            continue  # confidence, occlusion, orientation ...
        if not axis and m:
            axis = m.group(2).lower()
        if not joint and m:
            joint = m.group(1)
        if not joint or not axis:
            unnamed.append(f"channel {i} ({label or 'no label'}, type {kind or 'none'})")
            continue
        key = joint.lower()
        if key not in joints:
            joints[key] = [joint, {}]
            order.append(key)
        joints[key][1][axis] = i
        units = units or _text(ch, "unit")
    if unnamed:
        raise ParameterError(
            f"{who}: {', '.join(unnamed[:6])}"
            f"{' ...' if len(unnamed) > 6 else ''} name no joint or axis; "
            f"streamseg needs {CONVENTION}"
        )
    partial = [
        f"{joints[k][0]} (has {''.join(sorted(joints[k][1]))})"
        for k in order
        if len(joints[k][1]) != 3
    ]
    if partial:
        raise ParameterError(f"{who}: joints without all of x, y, z: {', '.join(partial[:8])}")
    if not order:
        raise ParameterError(f"{who} has no position channels: streamseg needs {CONVENTION}")
    return StreamSkeleton(
        tuple(joints[k][0] for k in order),
        tuple((joints[k][1]["x"], joints[k][1]["y"], joints[k][1]["z"]) for k in order),
        units or "unknown",
    )


def add_channels(desc, names, units: str = "millimeters") -> None:
    """Describe the channels of ``names`` (x, y, z each) on an outlet's ``desc()`` element,
    per the convention (for senders and tests)."""
    channels = desc.append_child("channels")
    for name in names:
        for axis in "XYZ":
            ch = channels.append_child("channel")
            ch.append_child_value("label", f"{name}_{axis}")
            ch.append_child_value("marker", name)
            ch.append_child_value("type", f"Position{axis}")
            ch.append_child_value("unit", units)
