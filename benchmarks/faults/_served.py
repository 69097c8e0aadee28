"""What the fault cases share: a ``streamseg serve`` subprocess, the good stream, checks."""

from __future__ import annotations

import functools
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import zmq

from streamseg import protocol as P
from streamseg.client import fetch_since, request
from streamseg.commands.replay import announce_of

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data" / "cmu86"
STEP = 20  # frames per packet of the good stream
MID = 2000  # the fault happens after this many good frames


@functools.cache
def recording():
    """CMU 86_01 (the good stream: 120 Hz, 9,294 frames)."""
    from streamseg.io import read

    return read(DATA / "86_01.amc.gz", skeleton=DATA / "86.asf")


def offline_cuts(rec, positions) -> list:
    """The cut detector's cuts of ``positions`` (frames), as the daemon makes them."""
    from streamseg.offline.lof import position_features
    from streamseg.online.lof import StreamingLOFSegmenter

    seg = StreamingLOFSegmenter(fps=rec.fps)
    ang = position_features(positions, rec.skeleton, rec.fps)
    return [c.frame for c in seg.learn_many(ang) + seg.finish()]


@functools.cache
def base_cuts() -> tuple:
    """The whole good stream's cuts without any fault."""
    rec = recording()
    return tuple(offline_cuts(rec, rec.positions))


def row(case: str, result: str, figure: str, passed: bool) -> dict:
    return {"case": case, "result": result, "figure": figure, "passed": bool(passed)}


def named(name: str):
    """Decorator: the case's name in the table and for ``--cases``."""

    def wrap(fn):
        fn.case = name
        return fn

    return wrap


class Served:
    """A `streamseg serve` subprocess on ipc endpoints in ``tmp``; ``daemon`` are ``[daemon]``
    settings of its TOML file (``state_dir`` defaults to ``tmp/state``)."""

    def __init__(self, tmp: Path, ring_start=None, endpoint=None, tmpfs_mb=None, **daemon):
        self.tmp = tmp
        self.ring_start = ring_start
        self.tmpfs_mb = tmpfs_mb  # the state directory on a tmpfs of this size (its own
        # user and mount namespace: nothing stays mounted; files at /proc/PID/root)
        # endpoint: e.g. "tcp://127.0.0.1:0" for all three (ports resolved at start)
        self.ep = {k: endpoint or f"ipc://{tmp}/{k}" for k in ("ingest", "publish", "control")}
        self.keys = None
        lines = [f'{k} = "{v}"' for k, v in self.ep.items()]
        daemon.setdefault("state_dir", str(tmp / "state"))
        daemon.setdefault("relabel_history", 20.0)
        daemon.setdefault("heartbeat", 0.5)
        for k, v in daemon.items():
            lines.append(
                f"{k} = {v!r}".replace("'", '"')
                if isinstance(v, str)
                else f"{k} = {str(v).lower() if isinstance(v, bool) else v}"
            )
        (tmp / "d.toml").write_text("[daemon]\n" + "\n".join(lines) + "\n")
        if "curve_dir" in daemon:
            from streamseg.daemon.security import ClientKeys

            self.keys = ClientKeys.load(daemon["curve_dir"])
        self.start()

    def start(self, log_level="ERROR", stderr=subprocess.DEVNULL) -> float:
        """Start the daemon; seconds until it answers a ping."""
        # ring_start: the feature ring's first size (a huge one: the ring allocated whole at
        # the first packet, as before it grew on demand)
        pre = (
            f"import streamseg.daemon.pipeline as p; p.RING_START = {self.ring_start}; "
            if self.ring_start
            else ""
        )
        cmd = [
            sys.executable,
            "-c",
            pre + "import sys; from streamseg.cli import main; sys.exit(main(sys.argv[1:]))",
            "serve",
            "--config",
            str(self.tmp / "d.toml"),
            "--log-level",
            log_level,
        ]
        if self.tmpfs_mb:
            state = self.tmp / "state"
            state.mkdir(exist_ok=True)
            cmd = [
                "unshare",
                "-rm",
                "sh",
                "-c",
                f'mount -t tmpfs -o size={self.tmpfs_mb}m tmpfs "{state}" && exec "$@"',
                "sh",
                *cmd,
            ]
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=stderr, text=True)
        line = self.proc.stdout.readline()  # "streamseg serve: ingest=EP publish=EP ..."
        self.ep.update(kv.split("=", 1) for kv in line.split()[2:] if "=" in kv)
        return self.wait_ping()

    def wait_ping(self, timeout=120) -> float:
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout:
            if self.proc.poll() is not None:
                raise RuntimeError(f"the daemon exited ({self.proc.returncode})")
            try:
                if self.request("ping", timeout=1)["ok"]:
                    return time.monotonic() - t0
            except TimeoutError:
                pass
        raise RuntimeError("the daemon does not answer")

    def request(self, op, timeout=10.0, **kw):
        return request(self.ep["control"], op, timeout=timeout, curve=self.keys, **kw)

    def push(self, keys=None):
        s = zmq.Context.instance().socket(zmq.PUSH)
        s.setsockopt(zmq.LINGER, 10000)
        if keys or self.keys:
            (keys or self.keys).apply(s)
        s.connect(self.ep["ingest"])
        return s

    def frame_of(self, stream):
        return {x["stream"]: x["frame"] for x in self.request("streams")["streams"]}.get(stream)

    def wait_frame(self, stream, frame, timeout=120):
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout:
            if self.frame_of(stream) == frame:
                return
            time.sleep(0.005)
        raise RuntimeError(f"{stream} never reached frame {frame}")

    def wait_closed(self, stream, timeout=120):
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout:
            st = self.request("state", stream=stream)
            if st.get("closed"):
                return st
            time.sleep(0.01)
        raise RuntimeError(f"{stream} not closed")

    def rss_peak_mb(self) -> float:
        with open(f"/proc/{self.proc.pid}/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
        return float("nan")

    def log(self, stream, timeout=120):
        """The stream's logged events once its ``closed`` event is among them."""
        t0 = time.monotonic()
        while True:
            events = fetch_since(self.ep["control"], stream, 0, curve=self.keys)
            if (events and events[-1].type == "closed") or time.monotonic() - t0 > timeout:
                return events
            time.sleep(0.02)

    def state(self) -> Path:
        """The state directory as this process reaches it (through the daemon's namespace)."""
        return (
            Path(f"/proc/{self.proc.pid}/root{self.tmp / 'state'}")
            if self.tmpfs_mb
            else self.tmp / "state"
        )

    def kill(self):
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait()

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(60)
            except subprocess.TimeoutExpired:
                self.proc.kill()


def send_good(sock, rec, lo, hi, stream="good"):
    """Frames ``[lo, hi)`` of ``rec`` as ``stream``, :data:`STEP` frames per packet."""
    for a in range(lo, hi, STEP):
        sock.send_multipart(
            P.encode(P.Frames(stream, a, 0.0, rec.positions[a : min(a + STEP, hi)]))
        )


def ckpt_frame(db, stream="good"):
    """The stream's checkpointed frame in the SQLite file (None: none yet)."""
    if not db.exists():
        return None
    con = sqlite3.connect(db)
    try:
        r = con.execute("SELECT frame FROM checkpoints WHERE stream = ?", (stream,)).fetchone()
    except sqlite3.Error:
        r = None
    con.close()
    return r[0] if r else None


def holes(events) -> int:
    """Numbers missing in a stream's logged events; the deliberate skip of SEQ_SKIP numbers
    at a crash restart (not events: numbers never used) is not counted."""
    seqs = [e.seq for e in events]
    return sum(b - a - 1 for a, b in zip(seqs, seqs[1:]) if b > a + 1 and b - a - 1 != P.SEQ_SKIP)


class Sender(threading.Thread):
    """Sends ``rec`` as ``stream`` in a loop, 20 frames per packet, about ``fps`` frames per
    second, until :meth:`stop`; packets sent while the daemon is down are lost, as a live
    sender's are."""

    def __init__(self, endpoint, rec, stream="k", fps=10_000):
        super().__init__(daemon=True)
        self.endpoint, self.rec, self.stream, self.fps = endpoint, rec, stream, fps
        self.stopping = threading.Event()

    def run(self):
        push = zmq.Context.instance().socket(zmq.PUSH)
        push.setsockopt(zmq.SNDHWM, 50)
        push.setsockopt(zmq.SNDTIMEO, 100)
        push.connect(self.endpoint)
        push.send_multipart(P.encode(announce_of(self.rec, self.stream)))
        a, n = 0, self.rec.n_frames
        while not self.stopping.is_set():
            idx = np.arange(a, a + STEP) % n
            try:
                push.send_multipart(
                    P.encode(P.Frames(self.stream, a, 0.0, self.rec.positions[idx]))
                )
            except zmq.Again:
                pass
            a += STEP
            self.stopping.wait(STEP / self.fps)
        push.close(linger=0)

    def stop(self):
        self.stopping.set()
        self.join(10)


def numbered(events) -> list:
    return [e for e in events if getattr(e, "seq", None) is not None]


def missing_from_log(control, seen) -> list:
    """The numbered events of ``seen`` the log does not hold as they were seen."""
    logged = {}
    for key in {e.stream or P.DAEMON_WIDE for e in seen}:
        logged.update({(key, e.seq): e for e in fetch_since(control, key, 0)})
    return [e for e in seen if logged.get((e.stream or P.DAEMON_WIDE, e.seq)) != e]


def drain(sub, ms=300) -> list:
    """Every event ``sub`` receives until it stays quiet for ``ms``."""
    out = []
    while sub.poll(ms):
        out.append(P.decode(sub.recv_multipart()))
    return out
