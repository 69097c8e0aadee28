"""Sources: event latency over LSL beside ZeroMQ replay.

Usage: python benchmarks/sources_latency.py [--latency-runs 3] [--speed 2]

(The reading speed of each format is in the speed suite: ``benchmarks/speed.py --bench
Read``.)

CMU 86_01 played in real time x ``--speed`` into a daemon (a `streamseg serve`
subprocess on loopback) two ways: frames pushed to its ZeroMQ ingest (as `streamseg replay`
does, one frame per packet), and samples pushed to an LSL outlet read by a `streamseg lsl`
subprocess (liblsl kept on this machine by an lsl_api.cfg written here). Latency of a cut:
from the push of the frame whose arrival decided it (``emitted_at``) to a subscriber
receiving the cut event; p50 / p99 over every cut of every run (so few samples: n shown).
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from pathlib import Path

import numpy as np
import zmq
from _common import DATA


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _lsl_config(folder: Path) -> Path:
    cfg = folder / "lsl_api.cfg"
    cfg.write_text(
        f"[ports]\nIPv6 = disable\nMulticastPort = {_free_port()}\n"
        f"BasePort = {_free_port()}\nPortRange = 64\n[multicast]\n"
        "ResolveScope = machine\nMachineAddresses = {127.0.0.1}\n"
        "ListenAddress = 127.0.0.1\n[lab]\n"
        f"SessionID = bench-{uuid.uuid4().hex[:10]}\nKnownPeers = {{127.0.0.1}}\n"
        "[log]\nlevel = -3\n"
    )
    return cfg


def _serve():
    cmd = [
        sys.executable,
        "-m",
        "streamseg.cli",
        "serve",
        "--ingest",
        "tcp://127.0.0.1:0",
        "--publish",
        "tcp://127.0.0.1:0",
        "--control",
        "tcp://127.0.0.1:0",
        "--state-dir",
        "none",
        "--relabel-interval",
        "0",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    line = proc.stdout.readline()
    return proc, dict(kv.split("=", 1) for kv in line.split(": ", 1)[1].split())


class Cuts(threading.Thread):
    """Receive a stream's cut events with their receipt time, until it is closed."""

    def __init__(self, ep, stream):
        from streamseg.client import subscribe

        super().__init__(daemon=True)
        self.sub = subscribe(ep["publish"], ep["control"], stream=stream)
        self.got = []

    def run(self):
        from streamseg.client import listen

        for ev in listen(self.sub, until_end=True, timeout=120):
            if ev.type == "cut":
                self.got.append((ev.emitted_at, time.perf_counter()))


def _paced(n, fps, speed, push):
    """Call ``push(i)`` for frames 0..n-1 at real time x speed; their push times."""
    pushed = np.zeros(n)
    t0 = time.perf_counter()
    for i in range(n):
        pause = t0 + i / (fps * speed) - time.perf_counter()
        if pause > 0:
            time.sleep(pause)
        push(i)
        pushed[i] = time.perf_counter()
    return pushed


def run_zmq(rec, ep, speed, stream):
    from streamseg import protocol
    from streamseg.commands.replay import announce_of

    cuts = Cuts(ep, stream)
    cuts.start()
    sock = zmq.Context.instance().socket(zmq.PUSH)
    sock.connect(ep["ingest"])
    sock.send_multipart(protocol.encode(announce_of(rec, stream)))
    pos = rec.positions
    pushed = _paced(
        rec.n_frames,
        rec.fps,
        speed,
        lambda i: sock.send_multipart(
            protocol.encode(protocol.Frames(stream, i, time.time(), pos[i : i + 1]))
        ),
    )
    sock.send_multipart(protocol.encode(protocol.End(stream)))
    cuts.join(120)
    sock.close()
    return [t - pushed[e] for e, t in cuts.got]


def run_lsl(rec, ep, speed, stream, env):
    import pylsl

    from streamseg.lsl.meta import add_channels

    info = pylsl.StreamInfo(
        "bench", "MoCap", 3 * rec.skeleton.n_joints, rec.fps, pylsl.cf_double64, stream
    )
    add_channels(info.desc(), rec.skeleton.names)
    out = pylsl.StreamOutlet(info)
    cuts = Cuts(ep, stream)
    cuts.start()
    bridge = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "streamseg.cli",
            "lsl",
            "--to",
            ep["ingest"],
            "--source-id",
            stream,
            "--up",
            "y",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=env,
    )
    while not out.wait_for_consumers(0.5):
        pass
    flat = rec.positions.reshape(rec.n_frames, -1)
    t_lsl = pylsl.local_clock()
    pushed = _paced(
        rec.n_frames,
        rec.fps,
        speed,
        lambda i: out.push_sample(flat[i].tolist(), t_lsl + i / rec.fps),
    )
    from streamseg.client import request

    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:  # all frames in, then end the stream
        st = {s["stream"]: s for s in request(ep["control"], "streams")["streams"]}
        if st.get(stream, {}).get("frame", 0) >= rec.n_frames:
            break
        time.sleep(0.05)
    bridge.terminate()
    bridge.wait(30)
    cuts.join(120)
    return [t - pushed[e] for e, t in cuts.got]


def latency(runs: int, speed: float) -> None:
    from streamseg.io import read

    folder = Path(tempfile.mkdtemp())
    os.environ["LSLAPICFG"] = str(_lsl_config(folder))
    env = dict(os.environ)
    rec = read(DATA / "cmu86/86_01.amc.gz", skeleton=DATA / "cmu86/86.asf")
    proc, ep = _serve()
    rows = {"replay over ZeroMQ (1 frame/packet)": [], "LSL outlet -> streamseg lsl": []}
    try:
        for r in range(runs):
            rows["replay over ZeroMQ (1 frame/packet)"] += run_zmq(rec, ep, speed, f"z{r}")
            rows["LSL outlet -> streamseg lsl"] += run_lsl(
                rec, ep, speed, f"lsl-{uuid.uuid4().hex[:6]}", env
            )
    finally:
        proc.terminate()
        proc.wait(30)
    print(
        f"{'transport (86_01 at x' + format(speed, 'g') + ')':<40}{'n':>4}"
        f"{'p50 ms':>9}{'p99 ms':>9}{'max ms':>9}"
    )
    base = None
    for name, lat in rows.items():
        ms = np.array(lat) * 1000
        p50, p99 = np.percentile(ms, 50), np.percentile(ms, 99)
        base = base or p50
        print(
            f"{name:<40}{len(ms):>4}{p50:>9.2f}{p99:>9.2f}{ms.max():>9.2f}  (p50 x{p50 / base:.2f})"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--latency-runs", type=int, default=3)
    ap.add_argument("--speed", type=float, default=2.0)
    args = ap.parse_args()
    latency(args.latency_runs, args.speed)


if __name__ == "__main__":
    main()
