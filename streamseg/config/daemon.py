"""The daemon's sockets, limits and cadence."""

from __future__ import annotations

from dataclasses import dataclass

from streamseg.config._base import _check
from streamseg.recording import UP_AXES


@dataclass(frozen=True)
class DaemonConfig:
    """Options of ``streamseg serve`` (TOML table ``[daemon]``; flags of the same names).

    Why each default is what it is: ``docs/decisions.md``; how the parts fit:
    ``docs/architecture.md``.

    Attributes
    ----------
    ingest, publish, control : str
        Endpoints bound: PULL frame packets, PUB events, REP control (``""``: no control).
    max_streams : int
        Streams held at once; a further announcement gets an ``error`` event.
    idle_timeout : float
        Seconds without a packet after which a stream is closed (reason ``idle``).
    relabel_interval, relabel_history : float
        Relabel every R seconds of stream time over the last H seconds (R = 0: never).
    label_memory : bool
        Keep each stream's actions (<= 130 kB) so one that returns after H gets its old id.
    heartbeat : float
        Seconds between ``stats`` events (0: none).
    max_packet_frames : int
        Largest frame count accepted in one packet (bounds memory per message).
    drain, drain_frames : int
        Most packets, and frames, taken from the socket before one vectorised pipeline step.
    coalesce_frames, coalesce_wait, coalesce_load : int, float, float
        While the loop is busy more than ``coalesce_load`` of its time (0: always), a stream's
        frames wait for more of its own until it holds ``coalesce_frames`` or its oldest
        waited ``coalesce_wait`` seconds (0: never wait); one pipeline step then takes them
        all. Below that load nothing waits.
    subscribe : tuple of str
        Publishers of frame packets to subscribe to (SUB), beside the PULL ``ingest``: no
        backpressure; a packet the publisher dropped shows as a ``gap``.
    subscribe_hwm : int
        Packets the subscription holds (fixed at connect); beyond, the publisher drops.
    ingest_hwm, hwm : int
        ZeroMQ high-water marks (messages): of ingest, per connection, fixed at bind (with
        the receiver's queue it bounds memory; senders wait), and of publish.
    ingest_bytes : int
        Bytes of packets queued before the pipeline, ZeroMQ's included; >= 4 max_message_bytes.
    default_skeleton, default_fps, default_up : str, float, str
        ASF file, rate and up axis for streams sent without announcement (``""``: refuse them).
    shutdown_relabel : float
        Seconds at most spent on final relabels at shutdown (then ``closed`` events follow).
    final_relabel_bytes : int
        Bytes of history that ended takes may hold while they wait for their final relabel
        (each its float64 features); a take that ends beyond it closes without one.
    repetitions : bool
        Count repetitions live (``rep`` events; 5-25 us of CPU per frame).
    relabel_processes : int
        Processes of the ``process`` backend's pool; > 0 alone also selects that backend.
    relabel_backend : str
        Where relabel jobs run: ``thread``, ``process`` or ``dask`` (``streamseg[dask]``).
    relabel_scheduler : str
        Dask scheduler address, e.g. ``tcp://10.0.0.5:8786`` (``""``: a local cluster).
    relabel_share : float
        Most share of time an in-thread relabel takes while jobs wait (1: no pause).
    state_dir : str
        Directory of ``events.sqlite`` and ``checkpoints.sqlite`` (``""``, serve ``none``: off).
    log_max_mb, log_max_days : float
        Event log retention: oldest events deleted beyond this size (MB) or age (days).
    checkpoint_interval : float
        Seconds between checkpoints of every open stream (0: none); a restart resumes them.
    max_message_bytes : int
        Largest ingest message (ZMQ_MAXMSGSIZE); ZeroMQ drops a larger one unread.
    max_seq_jump : float
        Seconds of frames a ``seq`` may jump ahead; beyond, the packet is dropped (``seq``).
    min_fps, max_fps : float
        Announced frame rates outside this range are refused (``field`` error).
    gap_events_per_s, stray_errors_per_s : float
        Rate limits of ``gap`` events and of ``unknown_stream`` errors; beyond, counted.
    max_streams_per_client : int
        Streams one client (CURVE key, else connection) may hold open (0: no quota).
    curve_dir : str
        Keys made by ``streamseg keys``: every socket uses CURVE (``""``: loopback only).
    insecure : bool
        Allow binding a non-loopback address without CURVE.
    gap_fill : float
        Longest gap (seconds) in a joint filled by interpolation; longer ones are skipped.
    settle : float
        Seconds of frames after a provisional cut the relabel that settles it (``confirm``
        or ``withdraw``) waits for; each cut makes such a relabel due then (0: cuts are
        not settled and the cadence alone relabels).
    focus : float
        The window of a relabel a cut made due starts this many seconds before the cut.
    markers : str
        A marker map (TOML, joint = marker or [markers]; ``streamseg info FILE`` prints a
        template) for streams that announce markers no skeleton names (``""``: none).
    """

    ingest: str = "tcp://127.0.0.1:5560"
    publish: str = "tcp://127.0.0.1:5561"
    control: str = "tcp://127.0.0.1:5562"
    max_streams: int = 2000
    idle_timeout: float = 60.0
    relabel_interval: float = 5.0
    relabel_history: float = 60.0
    label_memory: bool = True
    heartbeat: float = 1.0
    max_packet_frames: int = 12000
    drain: int = 16000
    drain_frames: int = 32768
    coalesce_frames: int = 24
    coalesce_wait: float = 0.2
    coalesce_load: float = 0.5
    ingest_hwm: int = 4
    subscribe: tuple = ()
    subscribe_hwm: int = 64
    hwm: int = 100000
    default_skeleton: str = ""
    default_fps: float = 120.0
    default_up: str = "y"
    shutdown_relabel: float = 5.0
    final_relabel_bytes: int = 64 << 20
    repetitions: bool = False
    relabel_processes: int = 0
    relabel_backend: str = "thread"
    relabel_scheduler: str = ""
    relabel_share: float = 0.25
    state_dir: str = ""
    log_max_mb: float = 256.0
    log_max_days: float = 7.0
    checkpoint_interval: float = 2.0
    max_message_bytes: int = 64 << 20
    ingest_bytes: int = 256 << 20
    max_seq_jump: float = 600.0
    min_fps: float = 0.5
    max_fps: float = 10000.0
    gap_events_per_s: float = 10.0
    stray_errors_per_s: float = 10.0
    max_streams_per_client: int = 1000
    curve_dir: str = ""
    insecure: bool = False
    gap_fill: float = 0.25
    settle: float = 8.0
    focus: float = 20.0
    markers: str = ""

    def __post_init__(self):
        for name in ("ingest", "publish"):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, str) and "://" in v,
                "a ZeroMQ endpoint like tcp://127.0.0.1:5560",
            )
        _check(
            "control",
            self.control,
            isinstance(self.control, str) and (self.control == "" or "://" in self.control),
            'an endpoint or "" (off)',
        )
        if isinstance(self.subscribe, list):  # TOML gives a list
            object.__setattr__(self, "subscribe", tuple(self.subscribe))
        _check(
            "subscribe",
            self.subscribe,
            isinstance(self.subscribe, tuple)
            and all(isinstance(e, str) and "://" in e for e in self.subscribe),
            'a list of endpoints, e.g. ["tcp://127.0.0.1:5570"]',
        )
        _check(
            "relabel_processes",
            self.relabel_processes,
            type(self.relabel_processes) is int and self.relabel_processes >= 0,
            "an integer >= 0",
        )
        _check(
            "relabel_backend",
            self.relabel_backend,
            self.relabel_backend in ("thread", "process", "dask"),
            'one of "thread", "process", "dask"',
        )
        _check(
            "relabel_scheduler",
            self.relabel_scheduler,
            isinstance(self.relabel_scheduler, str)
            and (self.relabel_scheduler == "" or "://" in self.relabel_scheduler),
            'a scheduler address like tcp://127.0.0.1:8786, or "" (a local cluster)',
        )
        _check(
            "coalesce_load",
            self.coalesce_load,
            isinstance(self.coalesce_load, (int, float))
            and not isinstance(self.coalesce_load, bool)
            and 0 <= self.coalesce_load <= 1,
            "a fraction in [0, 1]",
        )
        _check(
            "relabel_share",
            self.relabel_share,
            isinstance(self.relabel_share, (int, float)) and 0 < self.relabel_share <= 1,
            "a fraction in (0, 1]",
        )
        for name in (
            "max_streams",
            "max_packet_frames",
            "drain",
            "drain_frames",
            "coalesce_frames",
            "hwm",
            "ingest_hwm",
            "subscribe_hwm",
        ):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, int) and not isinstance(v, bool) and v >= 1,
                "an integer >= 1",
            )
        for name in ("idle_timeout", "relabel_history", "default_fps"):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0,
                "a number > 0 (seconds or Hz)",
            )
        for name in ("relabel_interval", "heartbeat", "shutdown_relabel", "coalesce_wait"):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, (int, float)) and not isinstance(v, bool) and v >= 0,
                "a number >= 0 (seconds; 0 turns it off)",
            )
        _check(
            "default_skeleton",
            self.default_skeleton,
            isinstance(self.default_skeleton, str),
            'a path to an ASF file or ""',
        )
        _check(
            "default_up",
            self.default_up,
            self.default_up in UP_AXES,
            f"one of {', '.join(UP_AXES)}",
        )
        _check("repetitions", self.repetitions, isinstance(self.repetitions, bool), "true or false")
        _check(
            "label_memory", self.label_memory, isinstance(self.label_memory, bool), "true or false"
        )
        _check("insecure", self.insecure, isinstance(self.insecure, bool), "true or false")
        for name in ("state_dir", "curve_dir"):
            _check(
                name,
                getattr(self, name),
                isinstance(getattr(self, name), str),
                'a directory path or ""',
            )
        _check(
            "markers",
            self.markers,
            isinstance(self.markers, str),
            'the path of a marker map (TOML) or ""',
        )
        for name in (
            "log_max_mb",
            "log_max_days",
            "max_seq_jump",
            "min_fps",
            "max_fps",
            "gap_events_per_s",
            "stray_errors_per_s",
        ):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0,
                "a number > 0",
            )
        _check(
            "gap_fill",
            self.gap_fill,
            isinstance(self.gap_fill, (int, float))
            and not isinstance(self.gap_fill, bool)
            and 0 <= self.gap_fill <= 60,
            "seconds >= 0 (0: fill no gap)",
        )
        for name in ("settle", "focus"):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v <= 600,
                "seconds in [0, 600]",
            )
        _check("max_fps", self.max_fps, self.max_fps >= self.min_fps, "a number >= min_fps")
        _check(
            "checkpoint_interval",
            self.checkpoint_interval,
            isinstance(self.checkpoint_interval, (int, float)) and self.checkpoint_interval >= 0,
            "a number >= 0 (seconds; 0 turns it off)",
        )
        for name in ("max_message_bytes", "max_streams_per_client"):
            v = getattr(self, name)
            _check(
                name,
                v,
                type(v) is int and v >= (name == "max_message_bytes"),
                "an integer >= 1" if name == "max_message_bytes" else "an integer >= 0",
            )
        _check(
            "final_relabel_bytes",
            self.final_relabel_bytes,
            type(self.final_relabel_bytes) is int and self.final_relabel_bytes >= 0,
            "an integer >= 0 (bytes; 0: no ended take waits for a final relabel)",
        )
        _check(
            "ingest_bytes",
            self.ingest_bytes,
            type(self.ingest_bytes) is int and self.ingest_bytes >= 4 * self.max_message_bytes,
            f"an integer >= 4 x max_message_bytes ({4 * self.max_message_bytes}): lower "
            "max_message_bytes for a smaller budget",
        )
