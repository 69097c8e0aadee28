"""Strict JSON out (docs/output.md): a number that is not finite prints as null, never as the
non-JSON tokens NaN or Infinity that Python's json module writes by default."""

from __future__ import annotations

import json
import threading

import numpy as np
import pytest
import zmq

from streamseg import protocol as P
from streamseg import strict_json
from streamseg.cli import main


def strict_loads(text: str):
    return json.loads(text, parse_constant=lambda c: pytest.fail(f"non-strict JSON: {c}"))


def test_non_finite_numbers_become_null_at_any_depth():
    obj = {
        "a": float("nan"),
        "b": [1.0, float("inf"), (np.float32("-inf"), 2)],
        "c": np.array([[0.5, np.nan]]),
        "d": {"e": np.float64("nan"), "f": np.int64(3)},
        "g": "NaN",
        "h": None,
        "i": True,
    }
    text = strict_json.dumps(obj)
    assert strict_loads(text) == {
        "a": None,
        "b": [1.0, None, [None, 2]],
        "c": [[0.5, None]],
        "d": {"e": None, "f": 3},
        "g": "NaN",
        "h": None,
        "i": True,
    }
    with pytest.raises(ValueError):  # what the module guards against: json's default
        json.dumps({"a": float("nan")}, allow_nan=False)


def test_listen_jsonl_prints_a_nan_from_the_wire_as_null(capsys):
    """A publisher's event whose score is NaN (msgpack carries it): `listen --jsonl` prints
    strict JSON, the score null, the other fields as sent."""
    pub = zmq.Context.instance().socket(zmq.PUB)
    pub.setsockopt(zmq.LINGER, 0)
    port = pub.bind_to_random_port("tcp://127.0.0.1")
    parts = P.encode(P.Cut("s", 10, 0.25, float("nan"), 12, True), seq=1)
    out = {}
    lis = threading.Thread(
        target=lambda: out.setdefault(
            "rc",
            main(
                [
                    "listen",
                    "--from",
                    f"tcp://127.0.0.1:{port}",
                    "--jsonl",
                    "--count",
                    "1",
                    "--timeout",
                    "60",
                ]
            ),
        )
    )
    lis.start()
    while lis.is_alive():  # until the listener has taken one (a SUB joins when it joins)
        pub.send_multipart(parts)
        lis.join(0.02)
    pub.close()
    assert out["rc"] == 0
    (line,) = capsys.readouterr().out.splitlines()
    assert "NaN" not in line
    ev = strict_loads(line)
    assert ev["score"] is None and (ev["type"], ev["frame"], ev["emitted_at"]) == ("cut", 10, 12)
