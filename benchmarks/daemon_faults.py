"""The daemon's fault catalogue: each fault against a `streamseg serve` subprocess with the
event log and checkpoints on, beside a good stream (CMU 86_01, 20 frames per packet, as fast
as the daemon takes it), one row per fault.

Run: ``.venv/bin/python benchmarks/daemon_faults.py [--faults none,garbage,...]``

Columns:

- ``events lost``: events of the good stream missing for a listener that reads the event log
  (``since``): holes in its sequence numbers, plus cuts of the no-fault run that are missing;
  for ``slow subscriber`` the events the slow SUB socket lost that the log did not give back.
- ``cuts = no-fault``: the good stream's cuts equal those of the no-fault run (for ``kill -9``:
  those of a no-fault run in which the frames between the last checkpoint and the crash were
  lost, the stated exception; for ``SIGTERM``: the offline cuts of the frames received).
- ``RSS peak MB``: the daemon's VmHWM (/proc) at the end of the run.
- ``recovery s``: after the fault, time until the daemon answers a control ping (for
  ``kill -9``: from the restart until the resumed stream took its next packet).
"""

from __future__ import annotations

import argparse
import os
import signal
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import msgpack
import numpy as np
import zmq

from streamseg import protocol as P
from streamseg.client import fetch_since, request, subscriber
from streamseg.commands.replay import announce_of
from streamseg.daemon.security import ClientKeys, generate
from streamseg.io import read
from streamseg.offline.lof import position_features
from streamseg.online.lof import StreamingLOFSegmenter

DATA = Path(__file__).resolve().parents[1] / "data" / "cmu86"
STEP = 20
MID = 2000  # the fault happens after this many good frames


def offline_cuts(rec, positions):
    seg = StreamingLOFSegmenter(fps=rec.fps)
    ang = position_features(positions, rec.skeleton, rec.fps)
    return [c.frame for c in seg.learn_many(ang) + seg.finish()]


class Served:
    """A `streamseg serve` subprocess on ipc endpoints in ``tmp``."""

    def __init__(self, tmp: Path, ring_start=None, **daemon):
        self.tmp = tmp
        self.ring_start = ring_start
        self.ep = {k: f"ipc://{tmp}/{k}" for k in ("ingest", "publish", "control")}
        self.keys = None
        lines = [f'{k} = "{v}"' for k, v in self.ep.items()]
        daemon.setdefault("state_dir", str(tmp / "state"))
        daemon.setdefault("relabel_history", 20.0)
        daemon.setdefault("heartbeat", 0.5)
        for k, v in daemon.items():
            lines.append(f"{k} = {v!r}".replace("'", '"') if isinstance(v, str)
                         else f"{k} = {str(v).lower() if isinstance(v, bool) else v}")
        (tmp / "d.toml").write_text("[daemon]\n" + "\n".join(lines) + "\n")
        if "curve_dir" in daemon:
            self.keys = ClientKeys.load(daemon["curve_dir"])
        self.start()

    def start(self):
        # ring_start: the feature ring's first size (a huge one: the ring allocated whole at
        # the first packet, as before it grew on demand), for the idle-memory comparison
        pre = (f"import streamseg.daemon.pipeline as p; p.RING_START = {self.ring_start}; "
               if self.ring_start else "")
        self.proc = subprocess.Popen([sys.executable, "-c", pre + "import sys; from streamseg."
                                      "cli import main; sys.exit(main(sys.argv[1:]))", "serve",
                                      "--config", str(self.tmp / "d.toml"), "--log-level",
                                      "ERROR"],
                                     stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        self.proc.stdout.readline()
        t0 = time.monotonic()
        self.wait_ping()
        return time.monotonic() - t0

    def wait_ping(self, timeout=120) -> float:
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout:
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

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(60)
            except subprocess.TimeoutExpired:
                self.proc.kill()


def send_good(sock, rec, lo, hi, stream="good"):
    for a in range(lo, hi, STEP):
        sock.send_multipart(P.encode(P.Frames(stream, a, 0.0, rec.positions[a:min(a + STEP,
                                                                                 hi)])))


def ckpt_frame(db):
    """The good stream's checkpointed frame in the SQLite file (None: none yet)."""
    if not db.exists():
        return None
    con = sqlite3.connect(db)
    try:
        row = con.execute("SELECT frame FROM checkpoints WHERE stream = 'good'").fetchone()
    except sqlite3.Error:
        row = None
    con.close()
    return row[0] if row else None


def holes(events) -> int:
    """Numbers missing in a stream's logged events; the deliberate skip of SEQ_SKIP numbers
    at a crash restart (not events: numbers never used) is not counted."""
    from streamseg.protocol import SEQ_SKIP

    seqs = [e.seq for e in events]
    return sum(b - a - 1 for a, b in zip(seqs, seqs[1:]) if b > a + 1 and b - a - 1 != SEQ_SKIP)


def drain(sub) -> list:
    out = []
    while sub.poll(300):
        out.append(P.decode(sub.recv_multipart()))
    return out


def run_fault(name, rec, base_cuts, tmp: Path) -> dict:
    opts = {}
    if name == "announce flood":
        generate(tmp / "keys", clients=2)
        opts = dict(curve_dir=str(tmp / "keys"), max_streams=2000, max_streams_per_client=1000)
    if name == "slow subscriber":
        opts = dict(hwm=100, gap_events_per_s=1e6)
    if name == "huge":
        opts = dict(max_message_bytes=64 << 20)
    d = Served(tmp, **opts)
    out = {"fault": name, "lost": 0, "equal": None, "rss": None, "recovery": None}
    try:
        good_keys = ClientKeys.load(tmp / "keys", "client2") if d.keys else None
        sock = d.push(good_keys)
        slow = None
        if name == "slow subscriber":
            slow = zmq.Context.instance().socket(zmq.SUB)
            slow.setsockopt(zmq.RCVHWM, 1)
            slow.setsockopt(zmq.SUBSCRIBE, b"")
            slow.connect(d.ep["publish"])
            time.sleep(0.3)
        live = subscriber(d.ep["publish"], stream="good", curve=d.keys)  # a normal listener
        time.sleep(0.3)
        seen = []
        sock.send_multipart(P.encode(announce_of(rec, "good")))
        send_good(sock, rec, 0, MID)
        d.wait_frame("good", MID)
        ref_cuts = base_cuts
        t_fault = time.monotonic()
        if name == "garbage":
            evil = d.push()
            rng = np.random.default_rng(0)
            for k in range(2000):
                evil.send_multipart([b"frames/good/", rng.bytes(int(rng.integers(1, 200)))])
                evil.send_multipart([b"frames/good/", msgpack.packb(
                    {"v": 1, "type": "frames", "stream": "good", "seq": k})])
                evil.send_multipart([b"one part only"])
            evil.close()
        elif name == "huge":
            evil = d.push()
            evil.send_multipart([b"frames/good/", b"\0" * (400 << 20)])
            evil.close(linger=0)
        elif name == "poisoned seq":
            sock.send_multipart(P.encode(P.Frames("good", 2**53 - 2, 0.0, rec.positions[:3])))
        elif name == "announce flood":
            evil = d.push()  # another key than the good stream's
            for k in range(10000):
                evil.send_multipart(P.encode(announce_of(rec, f"flood{k:05d}")))
            evil.close()
            d.wait_ping()
            while d.request("stats")["totals"]["errors_by_reason"].get("quota", 0) < 9000:
                time.sleep(0.05)  # the flood has been taken
            late = d.push(good_keys)  # a stream announced after the flood still gets a slot
            late.send_multipart(P.encode(announce_of(rec, "late")))
            send_good(late, rec, 0, 200, stream="late")
            d.wait_frame("late", 200)
            late.close()
        elif name == "slow subscriber":
            burst = d.push()
            burst.send_multipart(P.encode(announce_of(rec, "holes")))
            for a in range(0, 4000, 2):  # 2000 one-frame packets, every other frame lost
                burst.send_multipart(P.encode(P.Frames("holes", 2 * a, 0.0,
                                                       rec.positions[a:a + 1])))
            burst.send_multipart(P.encode(P.End("holes")))
            burst.close()
        elif name == "kill -9 and restart":
            db = tmp / "state" / "checkpoints.sqlite"
            while ckpt_frame(db) != MID:  # the periodic checkpoint (every 2 s) has it
                time.sleep(0.01)
            crash = MID + 400  # taken after the checkpoint: lost with the process
            send_good(sock, rec, MID, crash)
            d.wait_frame("good", crash)
            seen += drain(live)
            n1 = max(e.seq for e in seen)  # the first daemon's last event
            d.proc.send_signal(signal.SIGKILL)
            d.proc.wait()
            ckpt = ckpt_frame(db) or 0
            ref = rec.positions.copy()
            ref[ckpt:crash] = np.nan
            ref_cuts = offline_cuts(rec, ref)
            out["frames lost"] = crash - ckpt
            t_restart = time.monotonic()
            d.start()
            send_good(sock, rec, crash, crash + STEP)
            d.wait_frame("good", crash + STEP)
            out["recovery"] = time.monotonic() - t_restart
            send_good(sock, rec, crash + STEP, rec.n_frames)
        elif name == "SIGTERM during relabel":
            send_good(sock, rec, MID, 3600)  # relabels every 5 s of stream: one is due
            d.wait_frame("good", 3600)
            d.proc.send_signal(signal.SIGTERM)
            d.proc.wait(60)
            out["recovery"] = d.start()  # a restart: the stream was closed (shutdown)
            events = d.log("good")
            out["lost"] = holes(events)
            out["equal"] = [e.frame for e in events if e.type == "cut"] == \
                offline_cuts(rec, rec.positions[:3600])
            final = [e for e in events if e.type == "segments" and e.final]
            out["note"] = (f"final segments {'published' if final else 'MISSING'}, closed "
                           f"{events[-1].reason if events[-1].type == 'closed' else 'MISSING'}")
            out["rss"] = d.rss_peak_mb()
            return out
        if out["recovery"] is None:
            out["recovery"] = d.wait_ping()
        if name not in ("kill -9 and restart",):
            send_good(sock, rec, MID, rec.n_frames)
        sock.send_multipart(P.encode(P.End("good")))
        d.wait_closed("good")
        events = d.log("good")
        seen += drain(live)
        logged = {(e.seq, e) for e in events}
        cuts = [e.frame for e in events if e.type == "cut"]
        if name == "kill -9 and restart":  # the first daemon's cuts decided after its last
            cuts = [e.frame for e in events if e.type == "cut" and  # checkpoint: the stated
                    (e.seq > n1 or e.emitted_at < ckpt)]  # exception
        out["lost"] = holes(events) + len(set(ref_cuts) - set(cuts)) + \
            sum((e.seq, e) not in logged for e in seen)
        out["equal"] = cuts == ref_cuts
        if slow is not None:
            d.wait_closed("holes")
            got = []
            while slow.poll(300):
                got.append(P.decode(slow.recv_multipart()))
            logged = d.log("holes")
            mine = [e for e in got if getattr(e, "stream", None) == "holes"]
            by_seq = {e.seq: e for e in logged}
            missing = [s for s in range(1, max(by_seq) + 1) if s not in by_seq]
            out["note"] = (f"slow SUB got {len(mine)} of {len(logged)} events of 'holes'; the "
                           f"log returned the {len(logged) - len(mine)} it missed")
            out["lost"] += len(missing) + sum(by_seq[e.seq] != e for e in mine)
            slow.close(linger=0)
        if name == "announce flood":
            tot = d.request("stats")["totals"]
            out["note"] = (f"{tot['streams'] - 1} flood streams open (quota 1000), "
                           f"{tot['errors_by_reason'].get('quota', 0)} refused (quota); a "
                           f"stream announced after the flood by another key was accepted")
        if name in ("garbage", "huge", "poisoned seq"):
            tot = d.request("stats")["totals"]
            out["note"] = "errors " + ", ".join(f"{k} {v}" for k, v in
                                                sorted(tot["errors_by_reason"].items()))
        out["rss"] = d.rss_peak_mb()
        del t_fault
        return out
    finally:
        d.stop()


FAULTS = ["none", "garbage", "huge", "poisoned seq", "announce flood", "slow subscriber",
          "kill -9 and restart", "SIGTERM during relabel"]


def idle_memory(rec, tmp: Path, n: int = 2000, ring_start=None) -> tuple:
    """RSS of the daemon before and after ``n`` streams announce and send 4 frames each."""
    d = Served(tmp, ring_start=ring_start, max_streams=n + 10, max_streams_per_client=0,
               checkpoint_interval=0.0)
    try:
        time.sleep(0.5)
        with open(f"/proc/{d.proc.pid}/status") as fh:
            before = next(int(x.split()[1]) for x in fh if x.startswith("VmRSS:"))
        s = d.push()
        for k in range(n):
            sid = f"idle{k:05d}"
            a = announce_of(rec, sid)
            s.send_multipart(P.encode(a))
            s.send_multipart(P.encode(P.Frames(sid, 0, 0.0, rec.positions[:4])))
        d.wait_frame(f"idle{n - 1:05d}", 4)
        with open(f"/proc/{d.proc.pid}/status") as fh:
            after = next(int(x.split()[1]) for x in fh if x.startswith("VmRSS:"))
        return before / 1024, after / 1024, (after - before) / n
    finally:
        d.stop()


def checkpoint_cost(rec, repeats: int = 20) -> None:
    """Loop time to copy one stream's state, writer time to pack it, and bytes a round
    stores, for a stream that has sent 4 frames and one whose history is full (60 s at
    120 Hz): its first checkpoint (every chunk new) and the next ones, one checkpoint interval
    of frames apart (only the chunks that changed are stored)."""
    import statistics

    from streamseg.config import DaemonConfig
    from streamseg.daemon.checkpoint import snapshot
    from streamseg.daemon.pipeline import Algorithms, StreamPipeline
    from streamseg.daemon.state_codec import load, packable
    from streamseg.daemon.state_codec import stored as stored_bytes
    from streamseg.daemon.streams import StreamState

    alg = Algorithms()
    alg.warmup(relabel=False)
    hist = DaemonConfig().relabel_history
    step = int(DaemonConfig().checkpoint_interval * 120)
    print(f"\ncheckpoint cost per stream (relabel_history {hist:g} s, 120 Hz), median of "
          f"{repeats}")
    print(f"{'stream':>36} {'loop copy ms':>13} {'writer pack ms':>15} {'state kB':>9} "
          f"{'stored kB':>10} {'restore ms':>11}")
    full = int(hist * 120)
    for label, n, more in (("4 frames", 4, 0), (f"{full} frames (full), first", full, 0),
                           (f"{full} frames, each next {step}", full, step)):
        p = StreamPipeline(rec.skeleton, rec.fps, alg, hist)
        p.push(rec.positions[np.arange(n) % rec.n_frames], 0)
        st = StreamState("s", 1, rec.fps, p, 0.0)
        st.next_seq = n
        copy, pack, stored, restore, previous = [], [], [], [], set()
        for _ in range(repeats):
            if more:  # the next interval's frames
                p.push(rec.positions[np.arange(n, n + more) % rec.n_frames], n)
                n += more
                st.next_seq = n
            t0 = time.perf_counter()
            state = snapshot(st)
            t1 = time.perf_counter()
            chunks = {}
            blob = msgpack.packb(packable(state, chunks), use_bin_type=True)
            fresh = [stored_bytes(chunks[d]) for d in chunks.keys() - previous]
            t2 = time.perf_counter()
            held = {d: stored_bytes(c) for d, c in chunks.items()}
            t3 = time.perf_counter()  # what a restart does: unpack, rebuild derived arrays
            load(msgpack.unpackb(blob, raw=False), held)
            restore.append(time.perf_counter() - t3)
            copy.append(t1 - t0)
            pack.append(t2 - t1)
            stored.append(len(blob) + sum(len(c) for c in fresh))
            if more:
                previous = set(chunks)
        state_kb = sum(a.nbytes for a in _arrays(state)) / 1e3
        print(f"{label:>36} {statistics.median(copy) * 1e3:>13.3f} "
              f"{statistics.median(pack) * 1e3:>15.3f} {state_kb:>9.1f} "
              f"{statistics.median(stored if not more else stored[1:]) / 1e3:>10.1f} "
              f"{statistics.median(restore) * 1e3:>11.2f}")


def _arrays(tree):
    """The arrays of a :func:`streamseg.daemon.state_codec.dump` tree."""
    if isinstance(tree, list):
        for x in tree:
            yield from _arrays(x)
    elif isinstance(tree, dict):
        if "__nd__" in tree:
            yield tree["__nd__"][2]
        else:
            for v in tree.values():
                yield from _arrays(v)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--faults", default=",".join(FAULTS))
    ap.add_argument("--idle-streams", type=int, default=2000)
    ap.add_argument("--skip-checkpoint-cost", action="store_true")
    args = ap.parse_args()
    rec = read(DATA / "86_01.amc.gz", skeleton=DATA / "86.asf")
    if not args.skip_checkpoint_cost:
        checkpoint_cost(rec)
    base = offline_cuts(rec, rec.positions)
    rows = []
    for name in args.faults.split(","):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.monotonic()
            rows.append(run_fault(name, rec, base, Path(tmp)))
            rows[-1]["wall"] = time.monotonic() - t0
        r = rows[-1]
        print(f"{r['fault']}: lost {r['lost']}, equal {r['equal']}, rss {r['rss']:.0f} MB, "
              f"recovery {r['recovery']:.3f} s  {r.get('note', '')}", file=sys.stderr)
    print("\n| fault | events lost | cuts = no-fault | RSS peak MB | recovery s | note |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        note = r.get("note", "")
        if "frames lost" in r:
            note = (f"{r['frames lost']} frames between the last checkpoint and the crash lost "
                    f"(a gap event); cuts = those of a no-fault run with that gap")
        print(f"| {r['fault']} | {r['lost']} | {'yes' if r['equal'] else 'NO'} | "
              f"{r['rss']:.0f} | {r['recovery']:.3f} | {note} |")
    if args.idle_streams:
        print(f"\nidle streams: {args.idle_streams} streams, announce + 4 frames each")
        for label, start in (("feature ring grown on demand (now)", None),
                             ("feature ring allocated whole (before)", 10**9)):
            with tempfile.TemporaryDirectory() as tmp:
                before, after, per = idle_memory(rec, Path(tmp), args.idle_streams, start)
            print(f"{label:>40}: daemon RSS {before:.0f} -> {after:.0f} MB, {per:.0f} kB per "
                  f"stream")


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    threading.current_thread().name = "daemon-faults"
    main()
