"""The lines ``streamseg listen`` prints: one readable line or JSON object per event, the
state line of a late joiner, and each stream's final cuts once its withdraws are applied."""

from __future__ import annotations

import time

from streamseg import protocol


def json_event(ev) -> dict:
    """An event as ``listen --jsonl`` prints it (docs/output.md): its fields, with segments
    as ``{"start", "end", "label"}`` objects like ``segment --json`` prints them."""
    out = protocol.to_json(ev)
    if ev.type == "segments":
        out["segments"] = [
            {"start": int(a), "end": int(b), "label": int(lab)} for a, b, lab in ev.segments
        ]
    return out


def _json_state(state: dict) -> dict:
    segs = state.get("segments")
    if isinstance(segs, dict) and isinstance(segs.get("segments"), list):
        segs = dict(
            segs, segments=[{"start": a, "end": b, "label": lab} for a, b, lab in segs["segments"]]
        )
        state = dict(state, segments=segs)
    return state


def merged_runs(segments) -> list:
    """Consecutive segments of one label joined: ACA's segments are cycles of an action, a
    reader wants the actions."""
    runs = []
    for a, b, lab in segments:
        if runs and runs[-1][2] == lab and runs[-1][1] == a:
            runs[-1] = (runs[-1][0], b, lab)
        else:
            runs.append((a, b, lab))
    return runs


def format_event(ev) -> str:
    """One readable line per event."""
    t = ev.type
    if t == "cut":
        ms = f".{int(ev.time * 1000) % 1000:03d}"
        when = (
            time.strftime("%H:%M:%S", time.gmtime(ev.time)) + ms + "Z"
            if ev.time > 1e8
            else f"{ev.time:9.3f}s"
        )  # a sender clock, or stream seconds
        return (
            f"[{ev.stream}] cut      frame {ev.frame:7d}  t={when}  score "
            f"{ev.score:6.2f}  (emitted at frame {ev.emitted_at}, "
            f"{'pending' if ev.pending else 'provisional'})"
        )
    if t == "confirm":
        return (
            f"[{ev.stream}] confirm  frame {ev.frame:7d}  the pending cut stands "
            f"(at frame {ev.emitted_at})"
        )
    if t == "withdraw":
        why = "moved: a cut nearby follows" if ev.moved else "no cut there"
        return (
            f"[{ev.stream}] withdraw frame {ev.frame:7d}  the pending cut is taken back "
            f"(at frame {ev.emitted_at}, {why})"
        )
    if t == "segments":
        runs = merged_runs(ev.segments)
        segs = " ".join(f"{a}-{b}:{lab}" for a, b, lab in runs[:12])
        more = f" +{len(runs) - 12}" if len(runs) > 12 else ""
        return (
            f"[{ev.stream}] relabel  rev {ev.revision:3d}  frames {ev.start}-{ev.end}  "
            f"{len(runs)} runs of {len({r[2] for r in runs})} labels"
            f"{' FINAL' if ev.final else ''} ({ev.elapsed * 1000:.0f} ms): {segs}{more}"
        )
    if t == "error":
        return f"[{ev.stream or '-'}] error    {ev.reason} x{ev.count}: {ev.message}"
    if t == "gap":
        return f"[{ev.stream}] gap      frames {ev.expected}..{ev.got - 1} missing"
    if t == "rep":
        return f"[{ev.stream}] rep      #{ev.count} frames {ev.start}-{ev.end}"
    if t == "closed":
        return f"[{ev.stream}] closed   ({ev.reason}) after {ev.frames} frames"
    if t == "stats":
        tot = ev.totals
        return (
            f"[*] stats    up {ev.uptime:.1f}s  streams {tot.get('streams', 0)}  frames "
            f"{tot.get('frames', 0)}  events {tot.get('events', 0)}  errors "
            f"{tot.get('errors', 0)}"
        )
    return repr(ev)


class CutBook:
    """Each stream's cuts with its ``withdraw`` events applied (two-stage detector).

    :meth:`apply` returns, at a stream's ``closed`` event when the stream had pending cuts,
    the line ``{"type": "cuts", "stream", "frames", "withdrawn"}`` listing its cuts minus
    the withdrawn ones (the final cuts, in frame order); else None.
    """

    def __init__(self):
        self.cuts: dict = {}  # stream -> frames (emission order)
        self.withdrawn: dict = {}  # stream -> count; present once a pending cut was seen

    def apply(self, ev):
        stream = getattr(ev, "stream", None)
        if ev.type == "cut":
            self.cuts.setdefault(stream, []).append(ev.frame)
            if ev.pending:
                self.withdrawn.setdefault(stream, 0)
        elif ev.type == "withdraw":
            frames = self.cuts.get(stream, [])
            if ev.frame in frames:
                del frames[len(frames) - 1 - frames[::-1].index(ev.frame)]
                self.withdrawn[stream] = self.withdrawn.get(stream, 0) + 1
        elif ev.type == "closed":
            frames = self.cuts.pop(stream, [])
            if stream in self.withdrawn:
                return {
                    "type": "cuts",
                    "stream": stream,
                    "frames": sorted(frames),
                    "withdrawn": self.withdrawn.pop(stream),
                }
        return None


def _state_line(state: dict) -> str:
    seg = state.get("segments")
    if seg is None:
        segs = "none"
    else:  # in the unit of the relabel lines: runs of one label
        runs = merged_runs(seg["segments"])
        segs = (
            f"{len(runs)} runs of {len({r[2] for r in runs})} labels over "
            f"{seg['start']}-{seg['end']}"
        )
    return (
        f"[{state['stream']}] state    frame {state['frame']}  revision {state['revision']}  "
        f"{segs}  + {len(state['cuts'])} newer cuts"
        + (f"  closed ({state['closed']})" if state.get("closed") else "")
    )
