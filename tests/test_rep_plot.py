"""The repetition picture shows each repetition's duration, range of motion and likeness."""

import pytest

from streamseg.io import read
from streamseg.offline.repetition import RepetitionSegmenter

pytest.importorskip("matplotlib")


def test_the_picture_shows_each_repetitions_range_and_likeness(data_dir, tmp_path):
    """UI-PRMD m01 s01 (Vicon deep squat): a bar per repetition (its seconds), a dot at its
    range of motion in degrees, its likeness written in the bar; the PNG is written."""
    import matplotlib.pyplot as plt

    from streamseg.commands.rep import _sets
    from streamseg.plotting.repetitions import figure_repetitions, plot_repetitions

    seg = RepetitionSegmenter().fit(read(data_dir / "uiprmd" / "vicon" / "m01_s01.trc.gz"))
    sets = _sets(seg, None)
    reps = sets[0]["repetitions"]
    assert len(reps) == 10
    for given in (sets, None):  # the JSON's sets, and the segmenter's own
        fig = figure_repetitions(seg, given)
        _, bars, dots = fig.axes
        heights = sorted(round(p.get_height(), 3) for p in bars.patches)
        assert heights == sorted(round((r["end"] - r["start"]) / seg.fps_, 3) for r in reps)
        roms = sorted(float(line.get_ydata()[0]) for line in dots.get_lines())
        assert roms == sorted(r["rom_deg"] for r in reps) and min(roms) > 90
        written = sorted(t.get_text() for t in bars.texts)
        assert written == sorted(f"{r['likeness']:.2f}" for r in reps)
        assert sets[0]["rom_joint"] in fig.axes[0].get_legend().texts[-1].get_text()
        plt.close(fig)
    plot_repetitions(tmp_path / "reps.png", seg, sets)
    assert (tmp_path / "reps.png").read_bytes()[:4] == b"\x89PNG"
