"""The machine around a daemon under test: another local user, a full disk, IPv6 loopback.

Shared by the fault cases and by the tests that check the same faults at a small size
(``tests/test_daemon_limits.py``, ``tests/test_daemon_disk.py``).
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import socket
import subprocess
import tempfile

import zmq

NOBODY = 65534  # the uid and gid of ``nobody``


def in_child(fn, other_user: bool):
    """``fn(ctx)`` in a forked process with a fresh ZeroMQ context; returns its JSON-able
    result, or ``{"raised": "Type: message"}`` when it raised.

    ``other_user``: the child runs as uid/gid :data:`NOBODY` when this runs as root, else it
    is a process of this user that was not given the control token (its token file is
    elsewhere).
    """
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: only fresh sockets, no locks of the parent's threads
        try:
            os.close(r)
            if other_user and os.geteuid() == 0:
                os.setgroups([])
                os.setgid(NOBODY)
                os.setuid(NOBODY)
            elif other_user:
                os.environ["XDG_RUNTIME_DIR"] = "/nonexistent-streamseg"
                os.environ.pop("STREAMSEG_TOKEN", None)
            out = fn(zmq.Context())
        except BaseException as err:  # reported to the parent, which judges it
            out = {"raised": f"{type(err).__name__}: {err}"}
        os.write(w, json.dumps(out, allow_nan=False).encode())
        os._exit(0)
    os.close(w)
    with os.fdopen(r, "rb") as fh:
        data = fh.read()
    os.waitpid(pid, 0)
    return json.loads(data)


def can_mount() -> bool:
    """Whether a tmpfs can be mounted in a user and mount namespace here (``unshare -rm``),
    the small disk that :func:`fill` fills."""
    if not shutil.which("unshare"):
        return False
    with tempfile.TemporaryDirectory() as d:
        return (
            subprocess.run(
                ["unshare", "-rm", "sh", "-c", f"mount -t tmpfs -o size=1m tmpfs '{d}'"],
                capture_output=True,
            ).returncode
            == 0
        )


def fill(path) -> int:
    """Write ``path`` until its disk is full (ENOSPC); returns the bytes written."""
    n, block = 0, b"\0" * (1 << 16)
    with open(path, "wb", buffering=0) as fh:
        while True:
            try:
                n += fh.write(block)
            except OSError as err:
                if err.errno != errno.ENOSPC:
                    raise
                return n


def has_ipv6_loopback() -> bool:
    """Whether this machine can bind ``::1`` (some containers have no IPv6 at all)."""
    try:
        with socket.socket(socket.AF_INET6) as s:
            s.bind(("::1", 0))
        return True
    except OSError:
        return False
