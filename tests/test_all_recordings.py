"""Every bundled ASF/AMC recording parses, with constant bone lengths and valid features."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from streamseg.io import read
from streamseg.skeleton import bone_angles, quaternion_features

DATA = Path(__file__).resolve().parents[1] / "data"


def _recordings():
    out = [(DATA / "cmu86/86_01.amc.gz", DATA / "cmu86/86.asf")]
    out += [(f, DATA / "cmu86/86.asf") for f in sorted((DATA / "cmu_exercise").glob("*.amc.gz"))]
    out += [(f, DATA / "cmu02/02.asf") for f in sorted((DATA / "cmu02").glob("*.amc.gz"))]
    with open(DATA / "hdm05_reps/clips.csv") as fh:
        for row in csv.DictReader(fh):
            out.append(
                (
                    DATA / "hdm05_reps" / row["class"] / (row["file"] + ".gz"),
                    DATA / "hdm05_reps/asf" / f"HDM_{row['actor']}.asf",
                )
            )
    return out


RECORDINGS = _recordings()


def test_every_listed_file_is_bundled():
    assert len(RECORDINGS) == 1 + 2 + 10 + 188
    assert all(f.exists() and s.exists() for f, s in RECORDINGS)


@pytest.mark.parametrize("amc,asf", RECORDINGS, ids=[f.name.split(".")[0] for f, _ in RECORDINGS])
def test_recording(amc, asf):
    rec = read(amc, skeleton=asf)
    assert rec.n_frames > 0 and np.isfinite(rec.positions).all()
    par = rec.skeleton.parents
    lengths = np.linalg.norm(rec.positions[:, 1:] - rec.positions[:, par[1:]], axis=2)
    assert (np.abs(lengths - lengths[0]) <= 1e-6 * np.maximum(lengths[0], 1e-9)).all()
    a = bone_angles(rec.positions, rec.skeleton, inclinations=False)
    assert np.isfinite(a).all() and a.min() >= 0 and a.max() <= np.pi
    q = quaternion_features(rec).reshape(rec.n_frames, -1, 4)
    assert (np.sum(q[1:] * q[:-1], axis=2) >= 0).all()


def test_frame_counts_match_the_data_readme():
    with open(DATA / "cmu02/frames.csv") as fh:
        expected = {row["sequence"]: int(row["frames"]) for row in csv.DictReader(fh)}
    for seq, n in expected.items():
        assert read(DATA / f"cmu02/{seq}.amc.gz", skeleton=DATA / "cmu02/02.asf").n_frames == n
