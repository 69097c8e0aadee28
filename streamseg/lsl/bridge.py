"""LSL motion-capture streams fed to the daemon, one daemon stream per LSL stream.

A :class:`Bridge` resolves the LSL streams that match (type, name, source id) and starts a
:class:`Feeder` for each: it reads the stream's description (:mod:`streamseg.lsl.meta`),
announces the joints, and sends the samples as ``frames`` packets stamped with LSL time
(``timestamp`` of a packet = LSL time of its first sample, so event ``time``s are on the
lab's common clock). Samples missing between two timestamps are lost frames (the daemon's
gap handling: short gaps are filled, longer ones skipped). An outlet with a source id that
goes away and comes back is picked up again by the same inlet (LSL recovery); one without a
source id, or back after more than :data:`RESTART_S` seconds, starts the stream anew.
"""

from __future__ import annotations

import logging
import re
import threading

import numpy as np
import zmq

from streamseg import protocol
from streamseg.client import sending_context
from streamseg.endpoints import ipv6
from streamseg.exceptions import ParameterError
from streamseg.lsl import pylsl
from streamseg.lsl.meta import describe, stream_skeleton
from streamseg.protocol.auth import read_token

log = logging.getLogger("streamseg.lsl")

RESTART_S = 10.0  # an outlet silent for longer than this starts the daemon stream anew
UP_PROBE_S = 1.0  # seconds of samples the up axis is judged on (when not given)
_BAD = re.compile(r"[^A-Za-z0-9_.:@+=-]")


def stream_id_of(info: dict) -> str:
    """The daemon stream id of an LSL stream: its source id, else its name (characters a
    stream id may not hold replaced by ``_``)."""
    raw = info.get("source_id") or info.get("name") or "lsl"
    return _BAD.sub("_", raw)[:128] or "lsl"


def predicate(kind: str | None, name: str | None, source_id: str | None) -> str:
    """The XPath predicate LSL resolves streams by."""
    parts = [
        f"{k}='{v}'" for k, v in (("type", kind), ("name", name), ("source_id", source_id)) if v
    ]
    return " and ".join(parts) or "type='MoCap'"


class Feeder(threading.Thread):
    """One LSL inlet sent to the daemon as one stream.

    Parameters
    ----------
    info : pylsl.StreamInfo
        The resolved stream.
    endpoint : str
        The daemon's ingest endpoint.
    stream : str or None
        Daemon stream id (default :func:`stream_id_of`).
    up : str or None
        Up axis to announce; None: the axis the body stands along in the first second.
    curve : ClientKeys or None
    on_error : callable(str) or None
        Called with a one-line message when the stream cannot be used.
    markers : MarkerSet or None
        A marker map (``--markers MAP.toml``): a stream whose channels are its markers is
        sent as the joints it makes (:func:`streamseg.skeleton.marker_map.columns_for`).
    """

    def __init__(
        self,
        info,
        endpoint: str,
        stream: str | None = None,
        up: str | None = None,
        curve=None,
        on_error=None,
        on_open=None,
        ctx=None,
        markers=None,
    ):
        super().__init__(daemon=True, name=f"lsl-{info.name()}")
        self.info = info
        self.endpoint = endpoint
        self.meta = describe(info.as_xml())
        self.stream = stream or stream_id_of(self.meta)
        self.up = up
        self.curve = curve
        self.on_error = on_error or (lambda msg: log.error("%s", msg))
        self.on_open = on_open or (lambda msg: log.info("%s", msg))
        self.ctx = ctx  # None: the thread's own, which ends once its queue is out
        self.markers = markers
        self.marker_columns = None  # the map's columns, when it applies (_plan)
        self.marker_fill = None  # its lost markers placed (LiveMarkerFill), when it can
        self.stopping = threading.Event()
        self.frames_sent = 0
        self.error = None

    def stop(self) -> None:
        self.stopping.set()

    # -- the thread ----------------------------------------------------------------------
    def run(self) -> None:
        lsl = pylsl()
        try:
            inlet = lsl.StreamInlet(
                self.info,
                max_buflen=360,
                recover=bool(self.meta["source_id"]),
                processing_flags=lsl.proc_clocksync,
            )
            full = inlet.info(10.0)
            self._plan(full.as_xml())
        except (ParameterError, ValueError) as err:
            self.error = str(err)
            self.on_error(self.error)
            return
        except Exception as err:  # liblsl: lost or timed out before the description came
            self.error = f"LSL stream {self.meta['name']!r}: {type(err).__name__}: {err}"
            self.on_error(self.error)
            return
        with sending_context(self.ctx) as ctx:
            sock = ctx.socket(zmq.PUSH)
            sock.setsockopt(zmq.LINGER, 2000)
            if self.curve is not None:
                self.curve.apply(sock)
            ipv6(sock, self.endpoint)
            sock.connect(self.endpoint)
            try:
                self._pump(lsl, inlet, sock)
            finally:
                sock.close()
                inlet.close_stream()

    def _plan(self, xml: str) -> None:
        from streamseg.skeleton.joint_sets import complete

        skel = stream_skeleton(xml)
        self.fps = float(self.meta["nominal_srate"])
        if not self.fps > 0:
            raise ParameterError(
                f"LSL stream {self.meta['name']!r} has an irregular rate: "
                "motion capture needs its nominal_srate (frames per second)"
            )
        self.columns = np.asarray(skel.columns, dtype=np.int64)
        self.units = skel.units
        names = skel.names
        if self.markers is not None:
            from streamseg.exceptions import SkeletonError
            from streamseg.skeleton.marker_map import columns_for
            from streamseg.skeleton.marker_sets import JOINTS

            try:
                self.marker_columns = columns_for(self.markers, names)
            except SkeletonError as err:
                raise ParameterError(f"LSL stream {self.meta['name']!r}: {err}") from None
            if self.marker_columns is not None:
                from streamseg.skeleton.marker_fill import LiveMarkerFill, live_layout
                from streamseg.skeleton.marker_map import stream_markers

                layout = live_layout(self.markers, stream_markers(self.markers, names))
                self.marker_fill = None if layout is None else LiveMarkerFill(layout)
                names = JOINTS
        probe = np.zeros((1, len(names), 3))
        self.names, _ = complete(names, probe)  # pose models: trunk points added
        self.raw_names = names

    def _positions(self, chunk) -> np.ndarray:
        from streamseg.skeleton.joint_sets import complete

        data = np.asarray(chunk, dtype=np.float64)
        pos = data[:, self.columns]  # (n, J, 3)
        if self.marker_columns is not None:
            from streamseg.skeleton.marker_map import joints_of_markers

            if self.marker_fill is not None:  # lost markers placed as the daemon does
                pos, notes = self.marker_fill.fill(pos)
                for note in notes:
                    log.warning("LSL stream %r: %s", self.meta["name"], note)
            pos = joints_of_markers(pos, self.marker_columns)
        return complete(self.raw_names, pos)[1]

    def _announce(self, sock, positions: np.ndarray) -> None:
        from streamseg.skeleton.bones import upright_axis

        up = self.up or upright_axis(positions, self.names) or "y"
        parents = tuple(-1 for _ in self.names)
        msg = protocol.Announce(
            self.stream,
            self.fps,
            tuple(self.names),
            parents,
            self.units[:64],
            up,
            auth=self._auth(),
        )
        self._send(sock, protocol.encode(msg))
        self.on_open(
            f"LSL stream {self.meta['name']!r} (source id "
            f"{self.meta['source_id'] or 'none'}, {len(self.raw_names)} joints at "
            f"{self.fps:g} Hz, up {up}) -> stream {self.stream} at {self.endpoint}"
        )

    def _send(self, sock, parts) -> None:
        while not self.stopping.is_set():
            if sock.poll(500, zmq.POLLOUT):
                sock.send_multipart(parts)
                return

    def _pump(self, lsl, inlet, sock) -> None:
        probe, probe_ts = [], []
        announced = False
        seq, last_ts = 0, None
        step = 1.0 / self.fps
        while not self.stopping.is_set():
            try:
                # the first sample as soon as it comes, then what else is there: a chunk
                # read with a timeout would wait for the timeout (or a full chunk)
                first, when = inlet.pull_sample(timeout=0.2)
                if when is None:
                    continue
                chunk, stamps = inlet.pull_chunk(timeout=0.0, max_samples=4095)
                chunk, stamps = [first, *chunk], [when, *stamps]
            except Exception as err:  # LostError: the outlet is gone (no source id)
                self.on_open(
                    f"LSL stream {self.meta['name']!r} lost ({type(err).__name__}); "
                    f"ended stream {self.stream}"
                )
                break
            if not stamps:
                continue
            pos, ts = self._positions(chunk), np.asarray(stamps, dtype=np.float64)
            if not announced:
                probe.append(pos)
                probe_ts.append(ts)
                if self.up is None and (ts[-1] - probe_ts[0][0]) < UP_PROBE_S:
                    continue
                pos, ts = np.concatenate(probe), np.concatenate(probe_ts)
                self._announce(sock, pos)
                announced = True
            # frames missing between samples (the outlet paused or dropped) are lost frames
            jumps = (
                np.rint(
                    np.diff(np.concatenate([[ts[0] - step if last_ts is None else last_ts], ts]))
                    * self.fps
                )
                - 1
            )
            edges = [0, *np.flatnonzero(jumps[1:] > 0) + 1, len(ts)]
            for a, b in zip(edges[:-1], edges[1:]):
                lost = int(jumps[a]) if (a > 0 or last_ts is not None) else 0
                if lost * step > RESTART_S:
                    self._send(sock, protocol.encode(protocol.End(self.stream, self._auth())))
                    self.on_open(
                        f"LSL stream {self.meta['name']!r} was silent for "
                        f"{lost * step:.1f} s: stream {self.stream} starts anew"
                    )
                    self._announce(sock, pos[a:b])
                    seq = 0
                elif lost > 0:
                    seq += lost
                self._send(
                    sock, protocol.encode(protocol.Frames(self.stream, seq, float(ts[a]), pos[a:b]))
                )
                seq += b - a
                self.frames_sent += b - a
            last_ts = float(ts[-1])
        if announced:
            self._send_end(sock)

    def _auth(self):
        """The control token without CURVE: a bridge restarted after a crash takes its stream
        id back from the dead one's connection (docs/protocol.md, Security)."""
        return read_token() if self.curve is None else None

    def _send_end(self, sock) -> None:
        if sock.poll(1000, zmq.POLLOUT):
            sock.send_multipart(
                protocol.encode(protocol.End(self.stream, self._auth())), zmq.NOBLOCK
            )


class Bridge:
    """Resolve matching LSL streams and feed each to the daemon (a thread per stream).

    Parameters
    ----------
    endpoint : str
        Daemon ingest endpoint.
    kind, name, source_id : str or None
        What to resolve (LSL stream type, name, source id); default type ``MoCap``.
    up : str or None
        Up axis of every stream (None: judged per stream).
    stream : str or None
        Daemon stream id (only for a single LSL stream; default: its source id or name).
    markers : MarkerSet or None
        A marker map for streams whose channels are markers (see :class:`Feeder`).
    """

    def __init__(
        self,
        endpoint: str,
        kind: str | None = "MoCap",
        name: str | None = None,
        source_id: str | None = None,
        up: str | None = None,
        stream: str | None = None,
        curve=None,
        on_error=None,
        on_open=None,
        markers=None,
    ):
        self.endpoint = endpoint
        self.predicate = predicate(kind, name, source_id)
        self.up = up
        self.stream = stream
        self.curve = curve
        self.on_error = on_error
        self.on_open = on_open
        self.markers = markers
        self.feeders: dict = {}  # LSL source id (else uid) -> Feeder
        self.refused: set = set()
        self.stopping = threading.Event()
        self.thread = None

    def start(self) -> Bridge:
        pylsl()  # a missing pylsl is said before the thread starts
        self.thread = threading.Thread(target=self.run, daemon=True, name="lsl-resolver")
        self.thread.start()
        return self

    def run(self) -> None:
        lsl = pylsl()
        while not self.stopping.is_set():
            for info in lsl.resolve_bypred(self.predicate, 0, 1.0):
                # an outlet with a source id that comes back is the same stream: its inlet
                # recovers it (a new uid); one without is a new stream
                key = info.source_id() or info.uid()
                old = self.feeders.get(key)
                if key in self.refused or (old is not None and old.is_alive()):
                    continue
                if old is not None and old.error:
                    self.refused.add(key)
                    continue
                feeder = Feeder(
                    info,
                    self.endpoint,
                    self.stream,
                    self.up,
                    self.curve,
                    self.on_error,
                    self.on_open,
                    markers=self.markers,
                )
                self.feeders[key] = feeder
                feeder.start()
            self.stopping.wait(0.5)

    def stop(self, timeout: float = 5.0) -> None:
        self.stopping.set()
        for f in self.feeders.values():
            f.stop()
        for f in self.feeders.values():
            f.join(timeout)
        if self.thread is not None:
            self.thread.join(timeout)
