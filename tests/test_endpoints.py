"""ZeroMQ endpoint options (streamseg.endpoints), shared by the daemon and every client."""

from __future__ import annotations

import socket

import pytest

from benchmarks.faults._machine import has_ipv6_loopback
from streamseg import endpoints
from streamseg.client import control, listen, request, subscribe, subscription
from streamseg.commands.replay import replay
from streamseg.daemon import security

HAS_LO = "lo" in {name for _, name in socket.if_nameindex()}


@pytest.mark.parametrize(
    ("endpoint", "six"),
    [
        ("tcp://127.0.0.1:5560", False),
        ("tcp://localhost:5560", False),
        ("ipc:///tmp/streamseg-ingest", False),
        ("tcp://[::1]:5560", True),
        ("tcp://[::1]:0;[::1]:5560", True),
        ("tcp://lo:0;[::1]:5560", True),  # a source without brackets, an IPv6 destination
        ("tcp://127.0.0.1:0;127.0.0.1:5560", False),
    ],
)
def test_which_endpoints_need_ipv6(endpoint, six):
    assert endpoints.needs_ipv6(endpoint) is six


def test_the_daemon_and_the_client_share_one_helper():
    assert control.ipv6 is subscription.ipv6 is security.ipv6 is endpoints.ipv6


@pytest.mark.skipif(
    not has_ipv6_loopback() or not HAS_LO, reason="this machine has no ::1 or no interface lo"
)
def test_a_client_reaches_a_daemon_through_a_source_and_an_ipv6_destination(start_daemon, rec):
    """``tcp://lo:0;[::1]:PORT`` (connect from lo to ::1): the client turns IPv6 on for it as
    the daemon does (it did not, and such a connection never came up)."""
    loop6 = "tcp://[::1]:0"
    d, ep = start_daemon(ingest=loop6, publish=loop6, control=loop6)
    via = {k: "tcp://lo:0;" + v.removeprefix("tcp://") for k, v in ep.items()}
    assert request(via["control"], "ping", timeout=30)["ok"]
    sub = subscribe(via["publish"], via["control"], stream="src")
    replay(
        rec.__class__(rec.fps, rec.skeleton, rec.positions[:600]),
        via["ingest"],
        stream="src",
        speed=0,
        batch=50,
        wait=60,
    )
    events = list(listen(sub, stream="src", until_end=True, timeout=60))
    assert events[-1].type == "closed" and events[-1].frames == 600
    sub.close()
