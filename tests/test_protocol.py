"""Wire protocol v1: round trips, topics for prefix filtering, validation messages."""

from __future__ import annotations

import msgpack
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from streamseg import protocol as P

ids = st.text(alphabet="abcXYZ019_.:-", min_size=1, max_size=20)
finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
nat = st.integers(min_value=0, max_value=2**53 - 1)  # the protocol's integer range
small = st.integers(min_value=0, max_value=10_000)


@st.composite
def announces(draw):
    n = draw(st.integers(1, 40))
    joints = draw(st.lists(st.text(min_size=1, max_size=12), min_size=n, max_size=n))
    parents = [-1] + [draw(st.integers(-1, n - 1)) for _ in range(n - 1)]
    fps = draw(st.floats(min_value=1e-3, max_value=1e4))
    return P.Announce(
        draw(ids),
        fps,
        tuple(joints),
        tuple(parents),
        draw(st.sampled_from(["mm", "cm", "inch*0.45", "unknown"])),
        draw(st.sampled_from(["x", "y", "z", "-x", "-y", "-z"])),
    )


@st.composite
def frame_packets(draw):
    dtype = draw(st.sampled_from([np.float32, np.float64]))
    shape = (draw(st.integers(1, 6)), draw(st.integers(1, 8)), 3)
    pos = draw(hnp.arrays(dtype, shape, elements=st.floats(width=32)))
    ts = draw(st.floats(width=64))
    return P.Frames(draw(ids), draw(nat), ts, pos)


segments = st.lists(st.tuples(small, small, st.integers(0, 50)), max_size=10).map(tuple)
stats_maps = st.dictionaries(st.text(max_size=5), st.integers(0, 10**9), max_size=4)

messages = st.one_of(
    announces(),
    frame_packets(),
    ids.map(P.End),
    st.builds(P.Cut, ids, nat, finite, finite, nat, st.booleans()),
    st.builds(P.Segments, ids, nat, nat, nat, segments, st.booleans(), finite),
    st.builds(P.Rep, ids, nat, nat, nat, finite, nat),
    st.builds(P.Rep, ids, nat, nat, nat, finite, nat, st.one_of(st.none(), nat), nat),
    st.builds(
        P.Rep,
        ids,
        nat,
        nat,
        nat,
        finite,
        nat,
        st.one_of(st.none(), nat),
        nat,
        st.one_of(st.none(), finite),
        st.one_of(st.none(), finite),
        st.one_of(st.none(), st.sampled_from(["l_knee", "r_shoulder"])),
        st.one_of(st.none(), st.floats(0.0, 1.0)),
    ),
    st.builds(P.Gap, ids, nat, nat),
    st.builds(P.Error, st.one_of(st.none(), ids), st.text(max_size=10), st.text(max_size=30), nat),
    st.builds(P.Stats, finite, stats_maps, st.dictionaries(ids, stats_maps, max_size=3)),
    st.builds(P.Closed, ids, st.sampled_from(["end", "idle", "shutdown"]), nat),
)


@settings(max_examples=300, deadline=None)
@given(messages)
def test_decode_inverts_encode(msg):
    frames = P.encode(msg)
    assert len(frames) == 2 and all(isinstance(f, bytes) for f in frames)
    back = P.decode(frames)
    assert back == msg
    assert type(back) is type(msg)


@given(frame_packets())
@settings(max_examples=50, deadline=None)
def test_arrays_keep_dtype_shape_and_bits(msg):
    back = P.decode(P.encode(msg))
    assert back.positions.dtype == msg.positions.dtype
    assert back.positions.shape == msg.positions.shape
    assert back.positions.tobytes() == msg.positions.tobytes()


def test_topics_filter_by_type_then_stream():
    cut = P.encode(P.Cut("s1", 10, 0.1, 2.0, 50))[0]
    seg = P.encode(P.Segments("s1", 1, 0, 10, ((0, 10, 0),)))[0]
    cut10 = P.encode(P.Cut("s10", 10, 0.1, 2.0, 50))[0]
    stats = P.encode(P.Stats(1.0))[0]
    assert cut == b"cut/s1/" and stats == b"stats/*/"
    by_type = P.subscriptions(kind="cut")
    assert any(cut.startswith(p) for p in by_type) and any(cut10.startswith(p) for p in by_type)
    assert not any(seg.startswith(p) for p in by_type)
    by_stream = P.subscriptions(stream="s1")
    assert any(cut.startswith(p) for p in by_stream) and any(seg.startswith(p) for p in by_stream)
    # the trailing slash keeps stream s10 out of stream s1's subscription
    assert not any(cut10.startswith(p) for p in by_stream)
    assert P.subscriptions() == [b""]


def _body(**kw):
    return [b"frames/x/", msgpack.packb(kw, use_bin_type=True)]


def _frames_body(stream="x", shape=(2, 3, 3), nbytes=None, dtype="<f8", **extra):
    data = bytes(nbytes if nbytes is not None else int(np.prod(shape)) * 8)
    body = {
        "v": 1,
        "type": "frames",
        "stream": stream,
        "seq": 0,
        "timestamp": 0.0,
        "positions": {"dtype": dtype, "shape": list(shape), "data": data},
    }
    body.update(extra)
    return _body(**body)


@pytest.mark.parametrize(
    "frames, kind, words",
    [
        ([b"t", b"\xc1garbage"], "decode", "not valid msgpack"),
        ([b"t", msgpack.packb([1, 2])], "decode", "must be a msgpack map"),
        ([b"only one part"], "decode", "expected 2 message parts"),
        (_body(v=0, type="frames", stream="x"), "version", "version 0 is not supported"),
        (_body(type="frames", stream="x"), "version", "version None"),
        (_body(v=1, type="bogus"), "type", "unknown message type 'bogus'"),
        (_body(v=1, type="frames", stream="x", seq=0), "field", "lacks field 'timestamp'"),
        (_frames_body(nbytes=7), "array", "7 data bytes do not match shape"),
        (_frames_body(shape=(2, 3)), "array", "expected (n_frames >= 1, n_joints >= 1, 3)"),
        (_frames_body(dtype="<i4"), "array", "dtype ('<f4' or '<f8')"),
        (_frames_body(stream="a/b"), "field", "frames.stream='a/b' is invalid"),
        (
            _frames_body(seq=-1),
            "field",
            "frames.seq=-1 is invalid: expected an integer in [0, 2**53)",
        ),
    ],
)
def test_validation_names_the_problem(frames, kind, words):
    with pytest.raises(P.WireError) as info:
        P.decode(frames)
    assert info.value.kind == kind
    assert words in str(info.value)


def test_announce_validation():
    good = P.Announce("s", 120.0, ("root", "a"), (-1, 0))
    assert P.decode(P.encode(good)) == good
    assert good.up == "y"  # the Acclaim/BVH/Kinect convention when a sender omits it
    for bad in (
        P.Announce("s", 0.0, ("root",), (-1,)),
        P.Announce("s", 120.0, ("root", "a"), (-1, 5)),
        P.Announce("s", 120.0, ("root", "a"), (-1,)),
        P.Announce("s", 120.0, ("root", "a"), (-1, 0), "mm", "up"),
        P.Announce("s", 120.0, ("root", "a"), (-1, 0), "mm", ["y"]),
    ):
        with pytest.raises(P.WireError, match="announce"):
            P.decode(P.encode(bad))


def test_never_pickle():
    frames = P.encode(P.Frames("s", 0, 0.0, np.zeros((1, 2, 3))))
    assert b"numpy" not in frames[1] and b"\x80\x04" not in frames[1][:2]
    body = msgpack.unpackb(frames[1])
    assert body["positions"]["dtype"] == "<f8" and body["positions"]["shape"] == [1, 2, 3]


def test_json_view_has_type_and_fields():
    j = P.to_json(P.Segments("s", 2, 0, 10, ((0, 4, 1), (4, 10, 0)), True, 0.5))
    assert j == {
        "type": "segments",
        "stream": "s",
        "revision": 2,
        "start": 0,
        "end": 10,
        "segments": [[0, 4, 1], [4, 10, 0]],
        "final": True,
        "elapsed": 0.5,
    }


@pytest.mark.parametrize(
    "body,reason",
    [
        ({"v": 1, "type": [1], "stream": "s"}, "type"),  # unhashable type
        ({"v": 1, "type": {"a": 1}, "stream": "s"}, "type"),
        ({"v": 1, "type": 7}, "type"),
    ],
)
def test_non_string_type_is_a_wire_error(body, reason):
    with pytest.raises(P.WireError) as info:
        P.decode([b"frames/s/", msgpack.packb(body)])
    assert info.value.kind == reason


def test_frame_numbers_beyond_2_53_are_rejected():
    parts = P.encode(P.Frames("s", 2**60, 0.0, np.zeros((1, 2, 3))))
    with pytest.raises(P.WireError, match=r"seq=.*2\*\*53"):
        P.decode(parts)


def test_rep_measures_travel_and_an_older_sender_has_none():
    rep = P.Rep("s", 10, 70, 2, 0.7, 80, None, 0, 0.6, 84.5, "l_knee", 0.81)
    assert P.decode(P.encode(rep)) == rep
    assert P.to_json(rep)["rom_deg"] == 84.5 and P.to_json(rep)["rom_joint"] == "l_knee"
    old = {
        "v": 1,
        "type": "rep",
        "stream": "s",
        "start": 10,
        "end": 70,
        "count": 2,
        "time": 0.7,
        "emitted_at": 80,
    }
    back = P.decode([b"rep/s/", msgpack.packb(old)])
    assert (back.duration_s, back.rom_deg, back.rom_joint, back.likeness) == (None,) * 4
    for key, bad in (("likeness", 1.5), ("rom_deg", "wide"), ("rom_joint", 3)):
        with pytest.raises(P.WireError, match=key):
            P.decode([b"rep/s/", msgpack.packb({**old, key: bad})])
