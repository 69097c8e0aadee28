"""What the command line prints and draws explains itself: the confusion matrix names its
rows and columns, `segment --online` shows each cut's latency, an (H)ACA picture names the
method, the found and the human actions and draws a few labelled curves, and `segment` has no
`--labels` that would do nothing."""

from __future__ import annotations

import json

import matplotlib
import pytest

from streamseg.cli import build_parser, main

matplotlib.use("Agg")


@pytest.fixture
def take(data_dir):
    return [
        str(data_dir / "cmu86" / "86_01.amc.gz"),
        "--skeleton",
        str(data_dir / "cmu86" / "86.asf"),
    ]


@pytest.fixture
def labels(data_dir):
    return str(data_dir / "cmu86" / "labels_86_01.csv")


@pytest.fixture
def figures(monkeypatch):
    """Every figure the command saves (matplotlib's savefig, watched, still saving)."""
    from matplotlib.figure import Figure

    seen = []
    save = Figure.savefig

    def watch(self, *args, **kwargs):
        seen.append(self)
        return save(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", watch)
    return seen


def test_confusion_matrix_has_headers(capsys, take, labels):
    assert main(["eval", *take, "--labels", labels, "--method", "aca"]) == 0
    lines = capsys.readouterr().out.splitlines()
    i = next(i for i, line in enumerate(lines) if line.strip().startswith("confusion"))
    assert "rows: found clusters, columns: human actions" in lines[i]
    assert lines[i + 1].split() == ["cluster", "jump", "leg_kick", "punch", "walk"]
    rows = [line.split() for line in lines[i + 2 : i + 6]]
    assert [r[0] for r in rows] == ["0", "1", "2", "3"] and all(len(r) == 5 for r in rows)


def test_online_text_output_shows_each_cuts_latency(capsys, take):
    assert main(["segment", *take, "--online", "--json"]) == 0
    want = json.loads(capsys.readouterr().out)["cut_latency_s"]
    assert main(["segment", *take, "--online"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].split()[-4:] == ["label", "decided", "after", "s"]
    got = [float(line.split()[-1]) for line in lines[3 : 3 + len(want)]]
    assert got == pytest.approx(want, abs=0.006) and len(want) == 6


def test_segment_has_no_labels_option(capsys, take):
    help_text = build_parser()._subparsers._group_actions[0].choices["segment"].format_help()
    assert "--labels" not in help_text and "--sequence" not in help_text
    with pytest.raises(SystemExit) as exit_:
        main(["segment", *take, "--labels", "x.csv"])
    assert exit_.value.code == 2
    assert "unrecognized arguments: --labels" in capsys.readouterr().err


def test_haca_picture_names_the_method_and_the_actions(tmp_path, take, labels, figures):
    png = tmp_path / "haca.png"
    assert main(["eval", *take, "--labels", labels, "--method", "aca", "--plot", str(png)]) == 0
    (fig,) = figures
    assert png.stat().st_size > 10_000
    title = fig._suptitle.get_text()
    assert title.startswith("86_01: HACA, 4 actions (found)") and "ACA k=" not in title
    band, human, curves = fig.axes
    assert band.get_ylabel() == "HACA" and human.get_ylabel() == "human"
    assert {t.get_text() for t in human.texts} == {"walk", "jump", "punch", "leg_kick"}
    # every found action is named after the human action it is matched to
    assert all(t.get_text().startswith("id ") and "(" in t.get_text() for t in band.texts)
    assert 1 <= len(curves.lines) <= 3
    assert curves.get_legend() is not None
    assert all(line.get_label().startswith("PC") for line in curves.lines)


def test_flat_aca_picture_is_titled_aca(tmp_path, take, figures):
    png = tmp_path / "aca.png"
    assert (
        main(["segment", *take, "--method", "aca", "--flat", "--clusters", "4", "--plot", str(png)])
        == 0
    )
    (fig,) = figures
    assert fig._suptitle.get_text() == "86_01.amc.gz: ACA, 4 actions (given)"
    assert fig.axes[0].get_ylabel() == "ACA"
