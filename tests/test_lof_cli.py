"""``streamseg segment|eval --method lof`` on real data."""

from __future__ import annotations

import json

import numpy as np
import pytest

from streamseg import cli
from streamseg.config import LOFConfig


def _run(capsys, *argv):
    assert cli.main([str(a) for a in argv]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.fixture(scope="module")
def files(data_dir):
    return (
        data_dir / "cmu86" / "86_01.amc.gz",
        data_dir / "cmu86" / "86.asf",
        data_dir / "cmu86" / "labels_86_01.csv",
    )


def test_segment_json_online(capsys, files):
    amc, asf, _ = files
    out = _run(capsys, "segment", amc, "--skeleton", asf, "--method", "lof", "--online", "--json")
    assert out["method"] == "lof" and out["n_frames"] == 4579 and out["fps"] == 120.0
    cuts = out["cuts"]
    assert len(cuts) == len(out["cut_latency_frames"]) >= 1
    seg = out["segments"]
    assert [s["start"] for s in seg[1:]] == cuts and seg[0]["start"] == 0
    assert seg[-1]["end"] == 4579 and all(s["label"] is None for s in seg)
    assert all(a["end"] == b["start"] for a, b in zip(seg, seg[1:]))
    assert out["params"]["online"] and out["params"]["k"] == LOFConfig().k


def test_segment_options_and_paper_preset(capsys, files):
    amc, asf, _ = files
    out = _run(
        capsys, "segment", amc, "--skeleton", asf, "--method", "lof", "--preset", "paper", "--json"
    )
    assert "cut_latency_frames" not in out
    assert out["params"]["frames"]["window"] == 500 and out["params"]["k"] == 20
    out = _run(
        capsys,
        "segment",
        amc,
        "--skeleton",
        asf,
        "--method",
        "lof",
        "--window",
        "1.5",
        "--k",
        "7",
        "--bins",
        "12",
        "--json",
    )
    assert out["params"]["window_s"] == 1.5 and out["params"]["k"] == 7
    assert out["params"]["bins"] == 12
    assert out["params"]["refine_s"] == 0.8  # the default localisation; the paper: 0
    assert out["params"]["novelty"] == 0.15  # the default novelty check; the paper: none
    off = _run(
        capsys, "segment", amc, "--skeleton", asf, "--method", "lof", "--novelty", "0", "--json"
    )
    assert off["params"]["novelty"] == 0.0
    centre = _run(
        capsys, "segment", amc, "--skeleton", asf, "--method", "lof", "--refine", "0", "--json"
    )
    assert centre["params"]["refine_s"] == 0.0
    # the centre rule puts every cut at a window centre: window // 2 + a multiple of the step
    g = centre["params"]["frames"]
    assert centre["cuts"] and all((c - g["window"] // 2) % g["step"] == 0 for c in centre["cuts"])


def test_features_options_match_the_library(capsys, files, tmp_path):
    """--inclinations off runs on the paper's 8 angles, --up names the recording's axis,
    --root-speed sets or turns off the root speeds; each gives the cuts the library gives on
    the same features. A matrix of the 17 bone features alone runs without the root speeds."""
    import numpy as np

    from streamseg.config import LOFConfig
    from streamseg.io import read
    from streamseg.offline.lof import LOFSegmenter
    from streamseg.online.root_speed import root_speed_columns
    from streamseg.skeleton import bone_angles

    amc, asf, _ = files
    rec = read(amc, asf)
    for argv, kw, up in (
        (("--inclinations", "off"), dict(inclinations=False), None),
        ((), {}, None),
        (("--up", "x"), {}, "x"),
        (("--root-speed", "0"), dict(root_speed_max=0.0), None),
        (("--root-speed", "6"), dict(root_speed_max=6.0), None),
    ):
        out = _run(capsys, "segment", amc, "--skeleton", asf, "--method", "lof", *argv, "--json")
        cfg = LOFConfig(**kw)
        assert out["params"]["inclinations"] == cfg.inclinations
        assert out["params"]["root_speed_max"] == cfg.root_speed_max
        feats = bone_angles(rec.positions, rec.skeleton, inclinations=cfg.inclinations, up=up)
        if cfg.root_columns:
            feats = np.column_stack(
                [feats, root_speed_columns(rec.positions, rec.skeleton, rec.fps, cfg, up=up)]
            )
        assert out["cuts"] == LOFSegmenter(cfg, rec.fps).fit(feats).cuts_.tolist()
    bone = bone_angles(rec.positions, rec.skeleton)
    npy = tmp_path / "bone.npy"
    np.save(npy, bone)
    out = _run(capsys, "segment", npy, "--fps", "120", "--method", "lof", "--json")
    assert out["params"]["root_speed_max"] == 0.0
    off = LOFConfig(root_speed_max=0.0)
    assert out["cuts"] == LOFSegmenter(off, 120.0).fit(bone).cuts_.tolist()
    assert (
        cli.main(
            [
                "segment",
                str(amc),
                "--skeleton",
                str(asf),
                "--method",
                "lof",
                "--up",
                "z",
                "--inclinations",
                "off",
            ]
        )
        == 2
    )
    assert "no effect" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:  # argparse: not one of the axes
        cli.main(["segment", str(amc), "--skeleton", str(asf), "--method", "lof", "--up", "w"])
    assert exc.value.code == 2 and "--up" in capsys.readouterr().err


def test_eval_prints_scores_and_plot(capsys, files, tmp_path):
    amc, asf, labels = files
    png = tmp_path / "lof.png"
    out = _run(
        capsys,
        "eval",
        amc,
        "--skeleton",
        asf,
        "--method",
        "lof",
        "--labels",
        labels,
        "--online",
        "--plot",
        png,
        "--json",
    )
    # the scores are the library's metrics of the live cuts against the labels
    from streamseg.evaluation.labels import cut_windows, read_labels, true_cuts
    from streamseg.evaluation.metrics import cut_scores, latency_stats

    seg = _run(capsys, "segment", amc, "--skeleton", asf, "--method", "lof", "--online", "--json")
    segs = read_labels(labels, "86_01")
    truth = true_cuts(segs, 4579)
    want = cut_scores(seg["cuts"], truth, windows=cut_windows(segs)[: len(truth)], margin=60)
    assert out["n_true"] == 6 and out["true_cuts"] == truth and out["cuts"] == seg["cuts"]
    assert (out["precision"], out["recall"], out["f1"]) == (
        want["precision"],
        want["recall"],
        want["f1"],
    )
    assert out["f1"] >= 0.9  # the training recording (README): a floor, not a tautology
    lat = latency_stats(seg["cut_latency_frames"])
    assert out["latency_median_frames"] == lat["median"]
    assert out["latency_median_s"] == pytest.approx(lat["median"] / 120)
    assert out["schema"] == 1 and out["command"] == "eval" and out["plot"] == str(png)
    assert png.stat().st_size > 10_000


def test_matrix_needs_fps(capsys, tmp_path):
    m = tmp_path / "angles.npy"
    np.save(m, np.random.default_rng(0).uniform(0, np.pi, (600, 17)))
    assert cli.main(["segment", str(m), "--method", "lof", "--json"]) == 2
    assert "--fps" in capsys.readouterr().err
    out = _run(capsys, "segment", m, "--method", "lof", "--fps", "100", "--json")
    assert out["n_frames"] == 600 and out["fps"] == 100.0
    # the paper's preset takes the 8 angles; a width mismatch names the option that fits
    assert (
        cli.main(["segment", str(m), "--method", "lof", "--fps", "100", "--preset", "paper"]) == 2
    )
    assert "17 columns" in (err := capsys.readouterr().err) and "--inclinations on" in err
    m8 = tmp_path / "angles8.npy"
    np.save(m8, np.random.default_rng(0).uniform(0, np.pi, (600, 8)))
    assert cli.main(["segment", str(m8), "--method", "lof", "--fps", "100"]) == 2
    assert "--inclinations off" in capsys.readouterr().err
    out = _run(
        capsys, "segment", m8, "--method", "lof", "--fps", "100", "--inclinations", "off", "--json"
    )
    assert out["n_frames"] == 600 and out["params"]["inclinations"] is False
    # --up means nothing for a matrix (features already computed) or without inclinations
    assert cli.main(["segment", str(m), "--method", "lof", "--fps", "100", "--up", "z"]) == 2
    assert "--up" in capsys.readouterr().err


def test_early_delay_reports_first_emissions_and_keeps_the_final_cuts(capsys, files):
    """``--early-delay``: the final cuts are ``--delay``'s alone; each cut's first emission
    (a pending cut) is never later than its final decision, and on 86_01 earlier for some."""
    amc, asf, labels = files
    base = [
        "segment",
        amc,
        "--skeleton",
        asf,
        "--method",
        "lof",
        "--online",
        "--delay",
        "2",
        "--json",
    ]
    one = _run(capsys, *base)
    two = _run(capsys, *base, "--early-delay", "1.2")
    assert two["cuts"] == one["cuts"] and two["cut_latency_frames"] == one["cut_latency_frames"]
    assert "cut_first_latency_frames" not in one
    first, final = two["cut_first_latency_frames"], two["cut_latency_frames"]
    assert len(first) == len(final) == len(two["cuts"])
    assert all(a <= b for a, b in zip(first, final))
    assert any(a < b for a, b in zip(first, final))
    assert all(isinstance(f, int) for f in two["withdrawn_cuts"])
    ev = _run(
        capsys,
        "eval",
        amc,
        "--skeleton",
        asf,
        "--labels",
        labels,
        "--method",
        "lof",
        "--online",
        "--delay",
        "2",
        "--early-delay",
        "1.2",
        "--json",
    )
    assert ev["cuts"] == one["cuts"]
    assert ev["first_latency_median_frames"] <= ev["latency_median_frames"]
    assert ev["n_withdrawn"] == len(two["withdrawn_cuts"])
