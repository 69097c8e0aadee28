"""The daemon's sockets, limits and cadence."""

from __future__ import annotations

from dataclasses import dataclass

from streamseg.config._base import _check
from streamseg.recording import UP_AXES


@dataclass(frozen=True)
class DaemonConfig:
    """Options of ``streamseg serve`` (TOML table ``[daemon]``; flags of the same names).

    Attributes
    ----------
    ingest, publish, control : str
        ZeroMQ endpoints the daemon binds: PULL for frame packets, PUB for events, REP for
        control requests (``control=""`` disables it). Loopback by default.
    max_streams : int
        Streams held at once; a further announcement gets an ``error`` event.
    idle_timeout : float
        Seconds without a packet after which a stream is closed (reason ``idle``).
    relabel_interval, relabel_history : float
        Relabel each stream every R seconds of its own time over its last H seconds
        (``relabel_interval=0``: off); H also bounds each stream's buffer (60 s at 120 Hz:
        547 kB). Why these values: ``docs/decisions.md`` (Labels).
    label_memory : bool
        Keep a bounded memory of each stream's actions (at most 130 kB per stream,
        :class:`streamseg.config.memory.LabelMemoryConfig`) so an action that returns after
        ``relabel_history`` gets its old id; off, ids are carried only by the overlap of
        successive windows.
    heartbeat : float
        Seconds between ``stats`` events (0: none).
    max_packet_frames : int
        Largest frame count accepted in one packet (bounds memory per message).
    drain, drain_frames : int
        Most packets, and frames, taken from the socket before the per-stream computation
        runs once on all of them (the vectorised path; larger is faster, smaller has lower
        latency).
    ingest_hwm, hwm : int
        ZeroMQ high-water marks (messages) of the ingest and the publish socket. The ingest
        queue is what bounds the daemon's memory under overload (senders then wait): at most
        ``ingest_hwm`` packets are buffered, e.g. 2000 x 60 frames x 31 joints = 90 MB.
    default_skeleton, default_fps, default_up : str, float, str
        An ASF file whose skeleton (and this rate and up axis, one of ``x y z -x -y -z``)
        serves streams that send frames without an announcement; ``""`` requires
        announcements.
    shutdown_relabel : float
        Seconds at most spent on final relabels at shutdown (then ``closed`` events follow).
    repetitions : bool
        Count repetitions live (``rep`` events from
        :class:`streamseg.online.RepetitionCounter`; 5-25 us of CPU per frame, see
        docs/results.md). Off by default: ``rep`` events only where a client wants them.
    relabel_processes : int
        0: relabel in a thread of the daemon (ACA's Python parts share the GIL with ingest);
        N > 0: the worker thread hands each job to a pool of N processes.
    relabel_backend : str
        Where relabel jobs run: ``thread`` (a thread of the daemon), ``process`` (that thread
        hands each job to a pool of ``relabel_processes`` processes, at least 1) or ``dask``
        (each job goes to the Dask cluster of ``relabel_scheduler``, several at once; results
        are published as they return, in revision order per stream; a failed or lost job
        runs locally, with an ``error`` event ``relabel_backend``). ``dask`` needs
        ``pip install streamseg[dask]``.
    relabel_scheduler : str
        With ``relabel_backend = "dask"``: the scheduler's address, e.g.
        ``tcp://10.0.0.5:8786``; ``""`` starts a local cluster (one worker process per core,
        on 127.0.0.1).
    relabel_share : float
        With relabelling in a thread and jobs waiting, the worker pauses after each job so
        relabelling takes at most this share of the time (it shares the GIL with ingest):
        the pause is the job's CPU time x (1 / share - 1), so time it waited for the GIL is
        not counted as its own; 1 = no pause.
    receive_thread : bool
        Receive and decode packets in a thread of their own, overlapping the detector's
        GIL-free kernels. Faster for one high-rate stream of small packets, slower with many
        streams (each GIL hand-back after a kernel call waits for the receiver), hence off.
    state_dir : str
        Directory of the event log (``events.sqlite``) and the stream checkpoints
        (``checkpoints.sqlite``). ``""``: none (the library default); ``streamseg serve`` uses
        ``$XDG_STATE_HOME/streamseg`` (``~/.local/state/streamseg``) unless told
        ``--state-dir none``.
    log_max_mb, log_max_days : float
        Event log retention: the oldest events are deleted beyond this size (MB of live
        pages) or age (days).
    checkpoint_interval : float
        Seconds between checkpoints of every open stream's state (0: none); after a crash a
        restart with the same ``state_dir`` resumes each stream from its last checkpoint.
    max_message_bytes : int
        ZMQ_MAXMSGSIZE of the ingest socket: a larger message is dropped by ZeroMQ (and the
        sender's connection closed) before it takes memory.
    max_seq_jump : float
        Seconds (x fps frames) a packet's ``seq`` may jump ahead of the expected frame; a
        larger jump is an ``error`` (reason ``seq``) and the packet is dropped, so one bad
        number cannot make every later good packet a duplicate.
    min_fps, max_fps : float
        Announced frame rates outside this range are refused (``field`` error).
    gap_events_per_s, stray_errors_per_s : float
        Rate limits: ``gap`` events per stream, and first-of-a-kind ``error`` events about
        stream ids that are not open (``unknown_stream`` floods), per second. Beyond them the
        occurrences are counted and summarised in the ``error`` republished each heartbeat.
    max_streams_per_client : int
        Streams one client may hold open at once (a ``quota`` error beyond it), so one
        sender cannot take every slot. A client is its CURVE public key; without CURVE it is
        the peer's IP address (so all local senders share one quota). 0: no quota.
    curve_dir : str
        Directory made by ``streamseg keys``: with it every socket uses CURVE, the daemon
        takes ``server.key_secret`` and accepts only the client public keys in
        ``authorized/``. ``""``: no encryption (then only loopback binds, unless
        ``insecure``).
    insecure : bool
        Allow binding a non-loopback address without CURVE.
    gap_fill : float
        Longest gap (seconds) in a joint that is filled by interpolation; a longer one is
        skipped by the detectors and published as a ``gap`` event with ``filled: false``
        (0: fill none). As ``streamseg segment --gap-fill``; why 0.25: docs/decisions.md.
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
    ingest_hwm: int = 2000
    hwm: int = 100000
    default_skeleton: str = ""
    default_fps: float = 120.0
    default_up: str = "y"
    shutdown_relabel: float = 5.0
    repetitions: bool = False
    relabel_processes: int = 0
    relabel_backend: str = "thread"
    relabel_scheduler: str = ""
    relabel_share: float = 0.25
    receive_thread: bool = False
    state_dir: str = ""
    log_max_mb: float = 256.0
    log_max_days: float = 7.0
    checkpoint_interval: float = 2.0
    max_message_bytes: int = 64 << 20
    max_seq_jump: float = 600.0
    min_fps: float = 0.5
    max_fps: float = 10000.0
    gap_events_per_s: float = 10.0
    stray_errors_per_s: float = 10.0
    max_streams_per_client: int = 1000
    curve_dir: str = ""
    insecure: bool = False
    gap_fill: float = 0.25

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
        _check("receive_thread", self.receive_thread, isinstance(self.receive_thread, bool),
               "true or false")
        _check("relabel_processes", self.relabel_processes,
               type(self.relabel_processes) is int and self.relabel_processes >= 0,
               "an integer >= 0")
        _check("relabel_backend", self.relabel_backend,
               self.relabel_backend in ("thread", "process", "dask"),
               'one of "thread", "process", "dask"')
        _check("relabel_scheduler", self.relabel_scheduler,
               isinstance(self.relabel_scheduler, str)
               and (self.relabel_scheduler == "" or "://" in self.relabel_scheduler),
               'a scheduler address like tcp://127.0.0.1:8786, or "" (a local cluster)')
        _check("relabel_share", self.relabel_share,
               isinstance(self.relabel_share, (int, float)) and 0 < self.relabel_share <= 1,
               "a fraction in (0, 1]")
        for name in ("max_streams", "max_packet_frames", "drain", "drain_frames", "hwm",
                     "ingest_hwm"):
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
        for name in ("relabel_interval", "heartbeat", "shutdown_relabel"):
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
        _check("default_up", self.default_up, self.default_up in UP_AXES,
               f"one of {', '.join(UP_AXES)}")
        _check("repetitions", self.repetitions, isinstance(self.repetitions, bool),
               "true or false")
        _check("label_memory", self.label_memory, isinstance(self.label_memory, bool),
               "true or false")
        _check("insecure", self.insecure, isinstance(self.insecure, bool), "true or false")
        for name in ("state_dir", "curve_dir"):
            _check(name, getattr(self, name), isinstance(getattr(self, name), str),
                   'a directory path or ""')
        for name in ("log_max_mb", "log_max_days", "max_seq_jump", "min_fps", "max_fps",
                     "gap_events_per_s", "stray_errors_per_s"):
            v = getattr(self, name)
            _check(name, v, isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0,
                   "a number > 0")
        _check("gap_fill", self.gap_fill, isinstance(self.gap_fill, (int, float))
               and not isinstance(self.gap_fill, bool) and 0 <= self.gap_fill <= 60,
               "seconds >= 0 (0: fill no gap)")
        _check("max_fps", self.max_fps, self.max_fps >= self.min_fps, "a number >= min_fps")
        _check("checkpoint_interval", self.checkpoint_interval,
               isinstance(self.checkpoint_interval, (int, float)) and self.checkpoint_interval >= 0,
               "a number >= 0 (seconds; 0 turns it off)")
        for name in ("max_message_bytes", "max_streams_per_client"):
            v = getattr(self, name)
            _check(name, v, type(v) is int and v >= (name == "max_message_bytes"),
                   "an integer >= 1" if name == "max_message_bytes" else "an integer >= 0")
