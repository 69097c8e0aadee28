"""The service's fault catalogue: each fault against a `streamseg serve` subprocess with the
event log and checkpoints on, beside a good stream (CMU 86_01, 20 frames per packet, as fast
as the daemon takes it).

In the ``result`` column: ``events lost``: events of the good stream missing for a listener
that reads the event log (``since``): holes in its sequence numbers, plus cuts of the
no-fault run that are missing, plus events seen live that the log does not hold; for ``slow
subscriber`` the events the slow SUB socket lost that the log did not give back. ``cuts =
no-fault``: the good stream's cuts equal those of the no-fault run (for ``kill -9``: those of
a no-fault run in which the frames between the last checkpoint and the crash were lost, the
stated exception; for ``SIGTERM``: the offline cuts of the frames received). In ``figure``:
the daemon's RSS peak (VmHWM), and the recovery: after the fault, time until the daemon
answers a control ping (for ``kill -9``: from the restart until the resumed stream took its
next packet).
"""

from __future__ import annotations

import re
import signal
import statistics
import time
from pathlib import Path

import msgpack
import numpy as np
import zmq

from streamseg import protocol as P
from streamseg.client import subscriber
from streamseg.commands.replay import announce_of
from streamseg.daemon.security import ClientKeys, generate

from ._served import (
    MID,
    STEP,
    Served,
    ckpt_frame,
    drain,
    holes,
    named,
    offline_cuts,
    recording,
    row,
    send_good,
)
from ._served import base_cuts as base_cuts_of


def run_fault(name, tmp: Path) -> dict:
    """One fault beside the good stream; the old columns (see the module docstring)."""
    rec, base_cuts = recording(), list(base_cuts_of())
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
        if name == "garbage":
            evil = d.push()
            rng = np.random.default_rng(0)
            for k in range(2000):
                evil.send_multipart([b"frames/good/", rng.bytes(int(rng.integers(1, 200)))])
                evil.send_multipart(
                    [
                        b"frames/good/",
                        msgpack.packb({"v": 1, "type": "frames", "stream": "good", "seq": k}),
                    ]
                )
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
            last, still = -1, 0
            while still < 20:  # the refusals stand still for a second: the flood is taken
                n = d.request("stats")["totals"]["errors_by_reason"].get("quota", 0)
                still, last = (still + 1 if n == last else 0), n
                time.sleep(0.05)
            late = d.push(good_keys)  # a stream announced after the flood still gets a slot
            late.send_multipart(P.encode(announce_of(rec, "late")))
            send_good(late, rec, 0, 200, stream="late")
            d.wait_frame("late", 200)
            late.close()
        elif name == "slow subscriber":
            burst = d.push()
            burst.send_multipart(P.encode(announce_of(rec, "holes")))
            for a in range(0, 4000, 2):  # 2000 one-frame packets, every other frame lost
                burst.send_multipart(
                    P.encode(P.Frames("holes", 2 * a, 0.0, rec.positions[a : a + 1]))
                )
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
            d.kill()
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
            out["equal"] = [e.frame for e in events if e.type == "cut"] == offline_cuts(
                rec, rec.positions[:3600]
            )
            final = [e for e in events if e.type == "segments" and e.final]
            out["note"] = (
                f"final segments {'published' if final else 'MISSING'}, closed "
                f"{events[-1].reason if events[-1].type == 'closed' else 'MISSING'}"
            )
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
            cuts = [
                e.frame
                for e in events
                if e.type == "cut"  # checkpoint: the stated
                and (e.seq > n1 or e.emitted_at < ckpt)
            ]  # exception
        out["lost"] = (
            holes(events)
            + len(set(ref_cuts) - set(cuts))
            + sum((e.seq, e) not in logged for e in seen)
        )
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
            out["note"] = (
                f"slow SUB got {len(mine)} of {len(logged)} events of 'holes'; the "
                f"log returned the {len(logged) - len(mine)} it missed"
            )
            out["lost"] += len(missing) + sum(by_seq[e.seq] != e for e in mine)
            slow.close(linger=0)
        if name == "announce flood":
            tot = d.request("stats")["totals"]
            out["note"] = (
                f"{tot['streams'] - 1} flood streams open (quota 1000), "
                f"{tot['errors_by_reason'].get('quota', 0)} refused (quota); a "
                f"stream announced after the flood by another key was accepted"
            )
        if name in ("garbage", "huge", "poisoned seq"):
            tot = d.request("stats")["totals"]
            out["note"] = "errors " + ", ".join(
                f"{k} {v}" for k, v in sorted(tot["errors_by_reason"].items())
            )
        out["rss"] = d.rss_peak_mb()
        return out
    finally:
        d.stop()


def measure_checkpoint_cost(repeats: int = 20) -> list:
    """Medians (ms, kB) of the loop's time to copy one stream's state, the writer's to pack
    it, and the bytes a round stores, for a stream that has sent 4 frames and one whose
    history is full (60 s at 120 Hz): its first checkpoint (every chunk new) and the next
    ones, one checkpoint interval of frames apart (only the chunks that changed)."""
    from streamseg.config import DaemonConfig
    from streamseg.daemon.algorithms import Algorithms
    from streamseg.daemon.checkpoint import snapshot
    from streamseg.daemon.pipeline import StreamPipeline
    from streamseg.daemon.state_codec import load, packable
    from streamseg.daemon.state_codec import stored as stored_bytes
    from streamseg.daemon.streams import StreamState

    alg = Algorithms()
    alg.warmup(relabel=False)
    hist = DaemonConfig().relabel_history
    step = int(DaemonConfig().checkpoint_interval * 120)
    rec, out = recording(), []
    full = int(hist * 120)
    for label, n, more in (
        ("4 frames", 4, 0),
        (f"{full} frames (full), first", full, 0),
        (f"{full} frames, each next {step}", full, step),
    ):
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
        out.append(
            {
                "label": label,
                "copy": statistics.median(copy) * 1e3,
                "pack": statistics.median(pack) * 1e3,
                "state": sum(a.nbytes for a in _arrays(state)) / 1e3,
                "stored": statistics.median(stored if not more else stored[1:]) / 1e3,
                "restore": statistics.median(restore) * 1e3,
            }
        )
    return out


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


def _row(out: dict) -> dict:
    note = out.get("note", "")
    if "frames lost" in out:
        note = (
            f"{out['frames lost']} frames between the last checkpoint and the crash lost "
            f"(a gap event); cuts = those of a no-fault run with that gap"
        )
    result = f"{out['lost']} events lost, cuts {'=' if out['equal'] else '!='} no-fault" + (
        f"; {note}" if note else ""
    )
    figure = f"RSS peak {out['rss']:.0f} MB, recovery {out['recovery']:.3f} s"
    return row(out["fault"], result, figure, out["lost"] == 0 and out["equal"])


def _case(name: str):
    @named(name)
    def case(tmp: Path) -> dict:
        return _row(run_fault(name, tmp))

    case.__name__ = re.sub(r"\W+", "_", name).strip("_")
    return case


FAULTS = [
    "none",
    "garbage",
    "huge",
    "poisoned seq",
    "announce flood",
    "slow subscriber",
    "kill -9 and restart",
    "SIGTERM during relabel",
]


@named("checkpoint cost")
def checkpoint_cost(tmp: Path) -> dict:
    """Per stream: the loop's copy, the writer's packing, the bytes one round stores and a
    restore, for a stream with a full history; passes when a next round stores less than a
    fifth of the first (only the chunks that changed)."""
    m = measure_checkpoint_cost()
    first, nxt = m[1], m[2]
    figure = (
        f"full stream: loop copy {first['copy']:.3f} ms, writer pack {first['pack']:.3f}"
        f" ms, restore {first['restore']:.2f} ms; stored {first['stored']:.0f} kB the "
        f"first round, {nxt['stored']:.0f} kB each next; 4 frames: {m[0]['stored']:.1f}"
        f" kB"
    )
    return row(
        "checkpoint cost",
        "a full stream's state copied, packed, restored",
        figure,
        nxt["stored"] < first["stored"] / 5,
    )


CASES = [_case(n) for n in FAULTS] + [checkpoint_cost]
