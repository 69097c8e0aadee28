"""Stream a joint-positions CSV to a streamseg daemon: pyzmq and msgpack, nothing of streamseg.

    python clients/python/sender.py TAKE.csv [--to tcp://127.0.0.1:5560] [--stream ID]
        [--fps HZ] [--batch N] [--speed X] [--units mm] [--up y] [--keys DIR]

The CSV is the one ``streamseg segment`` reads (docs/guide/formats.md): a header naming each
coordinate ``<joint>_x, <joint>_y, <joint>_z`` (CMU/Acclaim, HDM05, BVH or Kinect joint names)
and optionally a ``time`` column in seconds, whose median step gives the frame rate when
``--fps`` does not. An empty cell or ``nan`` is a marker dropout: it is sent as NaN and the
daemon's gap filler handles it. Protocol v1 (docs/protocol.md): one ``announce`` (joint names,
``parents`` all -1: the daemon's features need only the names), ``frames`` packets of
``--batch`` frames (float64 little-endian, shape ``(n, n_joints, 3)``, ``seq`` = index of the
first frame), one ``end``. ``--speed 1`` (the default) paces the packets in real time, ``0``
sends as fast as the daemon takes them (PUSH waits when the daemon's queue is full). A template
for senders in other processes or languages; ``clients/c/sender.c`` is the same program in C.
"""

import csv
import math
import statistics
import struct
import sys
import time

import msgpack
import zmq
import zmq.auth

AXES = ("x", "y", "z")
SEPARATORS = "_.- :"
TIME_COLUMNS = {
    "time": 1.0,
    "timestamp": 1.0,
    "t": 1.0,
    "time_s": 1.0,
    "time_ms": 1e-3,
    "timestamp_ms": 1e-3,
}


def option(argv, name, default=None):
    """The value after ``name`` in argv (both removed), or ``default``."""
    if name not in argv:
        return default
    i = argv.index(name)
    value = argv[i + 1]
    del argv[i : i + 2]
    return value


def read_csv(path):
    """``(joints, rows, fps_from_time)``: joint names, per frame a flat list of n_joints * 3
    floats (NaN for empty cells), and the rate the time column gives (None without one)."""
    with open(path, newline="") as f:
        table = csv.reader(f)
        header = [h.strip() for h in next(table)]
        joints, columns, time_col, scale = [], {}, None, 1.0
        for i, name in enumerate(header):
            low = name.lower()
            if time_col is None and low in TIME_COLUMNS:
                time_col, scale = i, TIME_COLUMNS[low]
            elif len(name) > 2 and name[-2] in SEPARATORS and low[-1] in AXES:
                joint = name[:-2]
                if joint not in columns:
                    joints.append(joint)
                    columns[joint] = {}
                columns[joint][low[-1]] = i
        if not joints:
            sys.exit(f"{path}: no column is named <joint>_x / _y / _z")
        order = [columns[j][a] for j in joints for a in AXES if a in columns[j]]
        if len(order) != 3 * len(joints):
            sys.exit(f"{path}: every joint needs an _x, an _y and a _z column")
        rows, times = [], []
        for line in table:
            if not line:
                continue
            rows.append([float(line[c]) if line[c].strip() else math.nan for c in order])
            if time_col is not None:
                times.append(float(line[time_col]) * scale)
    # the median step, as streamseg's reader takes it: one late sample does not move it
    steps = [b - a for a, b in zip(times, times[1:]) if b > a]
    fps = round(1.0 / statistics.median(steps), 6) if steps else None
    return joints, rows, fps


def use_keys(sock, keys):
    """CURVE on ``sock``: zmq.auth reads ZeroMQ's certificate files made by streamseg keys."""
    try:
        sock.curve_publickey, sock.curve_secretkey = zmq.auth.load_certificate(
            f"{keys}/client.key_secret"
        )
        sock.curve_serverkey, _ = zmq.auth.load_certificate(f"{keys}/server.key")
    except (OSError, ValueError) as err:  # one line, not a traceback
        print(f"--keys {keys}: {err}: make the keys with `streamseg keys DIR`", file=sys.stderr)
        sys.exit(2)


def message(kind, stream, **fields):
    """A protocol v1 message: topic ``<type>/<stream>/`` and a msgpack body."""
    body = {"v": 1, "type": kind, "stream": stream, **fields}
    return [f"{kind}/{stream}/".encode(), msgpack.packb(body, use_bin_type=True)]


def frames_packet(stream, seq, timestamp, rows, n_joints):
    """A ``frames`` message: the rows as one little-endian float64 array (n, n_joints, 3)."""
    flat = [v for row in rows for v in row]
    data = struct.pack(f"<{len(flat)}d", *flat)
    positions = {"dtype": "<f8", "shape": [len(rows), n_joints, 3], "data": data}
    return message("frames", stream, seq=seq, timestamp=timestamp, positions=positions)


def main(argv):
    args = list(argv)
    endpoint = option(args, "--to", "tcp://127.0.0.1:5560")
    fps = option(args, "--fps")
    batch = int(option(args, "--batch", "12"))
    speed = float(option(args, "--speed", "1"))
    units = option(args, "--units", "mm")
    up = option(args, "--up", "y")
    keys = option(args, "--keys")
    stream = option(args, "--stream")
    if len(args) != 1 or batch < 1 or speed < 0:
        sys.exit(__doc__)
    path = args[0]
    joints, rows, fps_from_time = read_csv(path)
    fps = float(fps) if fps is not None else fps_from_time
    if fps is None or not fps > 0:
        sys.exit(f"{path}: no time column gives the frame rate: give --fps HZ")
    stream = stream or path.replace("\\", "/").rsplit("/", 1)[-1].rsplit(".", 1)[0]
    # a context of our own, terminated at the end: termination waits (up to the linger)
    # until the queued packets are out; pyzmq never terminates Context.instance() at exit,
    # so a script that just closes its socket and exits can lose its last packets and `end`
    ctx = zmq.Context()
    sock = ctx.socket(zmq.PUSH)
    sock.setsockopt(zmq.LINGER, 10_000)  # how long ctx.term() waits for the queue at the end
    if keys:
        use_keys(sock, keys)
    sock.connect(endpoint)
    sock.send_multipart(
        message(
            "announce",
            stream,
            fps=fps,
            joints=joints,
            parents=[-1] * len(joints),
            units=units,
            up=up,
        )
    )
    t0 = time.time()
    for seq in range(0, len(rows), batch):
        if speed > 0:  # real time (or a multiple): packet k leaves when its last frame is due
            due = t0 + (seq + batch) / fps / speed
            time.sleep(max(0.0, due - time.time()))
        sock.send_multipart(
            frames_packet(stream, seq, t0 + seq / fps, rows[seq : seq + batch], len(joints))
        )
    sock.send_multipart(message("end", stream))
    sock.close()
    ctx.term()
    print(f"{stream}: sent {len(rows)} frames of {len(joints)} joints at {fps:g} Hz", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
