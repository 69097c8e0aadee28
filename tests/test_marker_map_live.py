"""``--markers MAP.toml`` beyond single files: the daemon (``serve --markers``, ``markers`` in
its TOML config), the LSL input and ``eval --all``. A stream of markers is segmented as the
joints the map makes: the same events as a stream that sends those joints."""

from __future__ import annotations

import json

import numpy as np
import zmq

from streamseg import protocol as P
from streamseg.cli import main
from streamseg.client import listen, subscribe
from streamseg.skeleton.marker_sets import JOINTS
from tests.cli_words import FREE_PORTS

# the CMU joint of 86_01 that stands for each canonical joint of the map
CMU = {
    "pelvis": "root",
    "spine": "lowerback",
    "sternum": "thorax",
    "neck": "lowerneck",
    "l_shoulder": "lhumerus",
    "l_elbow": "lradius",
    "l_wrist": "lwrist",
    "r_shoulder": "rhumerus",
    "r_elbow": "rradius",
    "r_wrist": "rwrist",
    "l_hip": "lfemur",
    "l_knee": "ltibia",
    "l_ankle": "lfoot",
    "r_hip": "rfemur",
    "r_knee": "rtibia",
    "r_ankle": "rfoot",
}


def marker_take(rec, n_frames=None):
    """``(joints (n, 16, 3), marker names, markers (n, M, 3), map TOML text)``: the 16 joints
    of 86_01, each sent as a marker ``Mk`` in a shuffled order among markers the map does
    not name (the other joints of the take, named ``Xk``); the map is ``joint = "Mk"``."""
    names = list(rec.skeleton.names)
    pos = rec.positions[:n_frames]
    joints = np.stack([pos[:, names.index(CMU[j])] for j in JOINTS], axis=1)
    rng = np.random.default_rng(7)
    others = [n for n in names if n not in CMU.values()]
    columns = [("J", j) for j in range(len(JOINTS))] + [("X", n) for n in others]
    order = rng.permutation(len(columns))
    marker_names, arrays, label = [], [], {}
    for k, i in enumerate(order):
        kind, what = columns[i]
        marker_names.append(f"{'M' if kind == 'J' else 'X'}{k}")
        arrays.append(joints[:, what] if kind == "J" else pos[:, names.index(what)])
        if kind == "J":
            label[JOINTS[what]] = marker_names[-1]
    toml = "".join(f'{j} = "{label[j]}"\n' for j in JOINTS)
    return joints, marker_names, np.stack(arrays, axis=1), toml


def send(ep, stream, names, positions, fps, units="m"):
    ctx = zmq.Context.instance()
    sock = ctx.socket(zmq.PUSH)
    sock.connect(ep["ingest"])
    sock.send_multipart(
        P.encode(P.Announce(stream, fps, tuple(names), tuple([-1] * len(names)), units, "y"))
    )
    for a in range(0, positions.shape[0], 40):
        sock.send_multipart(P.encode(P.Frames(stream, a, a / fps, positions[a : a + 40])))
    sock.send_multipart(P.encode(P.End(stream)))
    sock.close(linger=10_000)


def events_of(sub, stream):
    """The stream's events up to its `closed`, without the fields that name the stream."""
    out = []
    for ev in listen(sub, stream=stream, until_end=True, timeout=60):
        out.append(
            {k: v for k, v in P.to_json(ev).items() if k not in ("stream", "seq", "elapsed")}
        )
    return out


def test_the_daemon_segments_markers_as_the_joints_the_map_makes(start_daemon, rec, tmp_path):
    joints, names, markers, toml = marker_take(rec)
    (tmp_path / "map.toml").write_text(toml)
    # (no relabels: their timing varies; the cuts do not)
    d, ep = start_daemon(markers=str(tmp_path / "map.toml"), relabel_interval=0)
    subs = {s: subscribe(ep["publish"], ep["control"], stream=s) for s in ("m", "j", "bad")}
    send(ep, "m", names, markers, rec.fps)
    send(ep, "j", JOINTS, joints, rec.fps)
    got_m, got_j = events_of(subs["m"], "m"), events_of(subs["j"], "j")
    assert sum(e["type"] == "cut" for e in got_j) >= 5 and got_j[-1]["type"] == "closed"
    assert got_m == got_j
    # markers the map lacks, and no skeleton either: one error naming what the map lacks
    pelvis = toml.split('"')[1]  # the pelvis's marker
    keep = [i for i, n in enumerate(names) if n != pelvis]
    send(ep, "bad", [names[i] for i in keep], markers[:200, keep], rec.fps)
    ev = next(e for e in listen(subs["bad"], stream="bad", timeout=30) if e.type == "error")
    assert (
        ev.reason == "skeleton"
        and "nor are they the markers of map.toml (--markers)" in ev.message
        and f"pelvis ({pelvis})" in ev.message
    )
    # a stream of joints is segmented as announced beside the map
    sub = subscribe(ep["publish"], ep["control"], stream="plain")
    send(ep, "plain", JOINTS, joints[:1200], rec.fps)
    assert events_of(sub, "plain")[-1] == {"type": "closed", "reason": "end", "frames": 1200}


def test_serve_takes_the_map_from_its_option_or_its_config(tmp_path, capsys):
    from streamseg.daemon import load_config

    (tmp_path / "conf").mkdir()
    (tmp_path / "conf" / "serve.toml").write_text('[daemon]\nmarkers = "lab.toml"\n')
    config = load_config(tmp_path / "conf" / "serve.toml")[0]
    assert config.markers == str(tmp_path / "conf" / "lab.toml")  # beside the config file
    # a missing or bad map: one line, before any socket is bound
    for extra in (
        ["--markers", str(tmp_path / "nope.toml")],
        ["--config", str(tmp_path / "conf" / "serve.toml")],
    ):
        assert (
            main(
                [
                    "serve",
                    "--state-dir",
                    "none",
                    *FREE_PORTS,
                    *extra,
                ]
            )
            == 2
        )
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--markers" in err[0] and "no such file" in err[0], err


def _trc(path, names, xyz, fps):
    n = xyz.shape[0]
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{path.name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits",
        f"{fps:g}\t{fps:g}\t{n}\t{len(names)}\tm",
        "Frame#\tTime\t" + "\t\t\t".join(names),
        "\t\t" + "\t".join(f"{a}{i + 1}" for i in range(len(names)) for a in "XYZ"),
        "",
    ]
    lines += [
        f"{f + 1}\t{f / fps:.5f}\t" + "\t".join(repr(float(v)) for v in xyz[f].ravel())
        for f in range(n)
    ]
    path.write_text("\n".join(lines) + "\n")


def test_eval_all_reads_the_folders_markers_through_the_map(rec, data_dir, tmp_path, capsys):
    joints, names, markers, toml = marker_take(rec)
    folder = tmp_path / "lab"
    folder.mkdir()
    _trc(folder / "86_01.trc", names, markers, rec.fps)
    (folder / "labels.csv").write_text((data_dir / "cmu86" / "labels_86_01.csv").read_text())
    (tmp_path / "map.toml").write_text(toml)
    # without the map: one line naming --markers
    assert main(["eval", "--all", str(folder), "--method", "lof"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--markers MAP.toml" in err[0], err
    assert (
        main(
            [
                "eval",
                "--all",
                str(folder),
                "--method",
                "lof",
                "--markers",
                str(tmp_path / "map.toml"),
                "--json",
            ]
        )
        == 0
    )
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert {(r["recording"], r["method"]) for r in rows} == {
        ("86_01", "LOF streaming"),
        ("86_01", "LOF offline"),
    }
    # the same figures as the take's joints read from a file that names them
    _trc(tmp_path / "86_01.trc", JOINTS, joints, rec.fps)
    assert main(["segment", str(tmp_path / "86_01.trc"), "--online", "--json"]) == 0
    want = json.loads(capsys.readouterr().out)["cuts"]
    assert (
        main(
            [
                "segment",
                str(folder / "86_01.trc"),
                "--online",
                "--json",
                "--markers",
                str(tmp_path / "map.toml"),
            ]
        )
        == 0
    )
    assert json.loads(capsys.readouterr().out)["cuts"] == want and len(want) >= 5


def pelvis_cluster_take(rec):
    """``(joints, marker names, markers, map TOML)`` as :func:`marker_take`, the pelvis sent as
    four markers ``P0``-``P3`` fixed to the pelvis (lateral from the right to the left hip,
    up the lower back) whose mean is the pelvis joint: a cluster of the map."""
    joints, names, markers, toml = marker_take(rec)
    pel, lhip, rhip, spine = (
        joints[:, JOINTS.index(j)] for j in ("pelvis", "l_hip", "r_hip", "spine")
    )
    lat = lhip - rhip
    lat /= np.linalg.norm(lat, axis=1, keepdims=True)
    up = spine - pel
    up -= np.sum(up * lat, axis=1, keepdims=True) * lat
    up /= np.linalg.norm(up, axis=1, keepdims=True)
    fwd = np.cross(up, lat)
    offsets = ((0.12, 0.08, 0.02), (-0.12, 0.08, 0.02), (0.09, -0.08, -0.02), (-0.09, -0.08, -0.02))
    cluster = [pel + a * lat + b * fwd + c * up for a, b, c in offsets]
    pelvis = toml.split('"')[1]
    keep = [i for i, n in enumerate(names) if n != pelvis]
    names = [names[i] for i in keep] + [f"P{k}" for k in range(4)]
    markers = np.concatenate([markers[:, keep], np.stack(cluster, axis=1)], axis=1)
    toml = toml.replace(f'"{pelvis}"', '["P0", "P1", "P2", "P3"]')
    return joints, names, markers, toml


def test_the_daemon_places_a_lost_marker_from_its_cluster(start_daemon, rec, tmp_path):
    joints, names, markers, toml = pelvis_cluster_take(rec)
    lost = markers.copy()
    lost[300:900, names.index("P0")] = np.nan  # 5 s: much longer than the gap filler's 0.25 s
    (tmp_path / "map.toml").write_text(toml)
    d, ep = start_daemon(markers=str(tmp_path / "map.toml"), relabel_interval=0)
    subs = {s: subscribe(ep["publish"], ep["control"], stream=s) for s in ("m", "j")}
    send(ep, "m", names, lost, rec.fps)
    send(ep, "j", JOINTS, joints, rec.fps)
    got_m, got_j = events_of(subs["m"], "m"), events_of(subs["j"], "j")
    said = [e for e in got_m if e["type"] == "error" and e["reason"] == "markers"]
    assert (
        len(said) == 1
        and "marker P0 lost: placed from the markers of its segment" in (said[0]["message"])
    )
    got_m = [e for e in got_m if e not in said]
    # the pelvis placed by the rigid motion of P1-P3: no gap, the cuts of the joints' stream
    assert not any(e["type"] == "gap" for e in got_m)
    assert [(e["type"], e.get("frame")) for e in got_m] == [
        (e["type"], e.get("frame")) for e in got_j
    ]
    assert sum(e["type"] == "cut" for e in got_j) >= 5
