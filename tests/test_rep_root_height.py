"""The root-height column of the repetition segmenter (``root_height_weight``; issue 14).

Material: four real HDM05 squat clips of actor bd concatenated (the ``bd_squats`` fixture,
data/README.md).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from streamseg.config import RepetitionConfig
from streamseg.exceptions import ParameterError
from streamseg.offline.repetition import RepetitionSegmenter
from streamseg.offline.root_height import root_height, with_root_height


@pytest.fixture(scope="module")
def squats(bd_squats):
    return bd_squats[0]


def _h(rec, positions=None, up=None):
    return root_height(rec.positions if positions is None else positions, rec.skeleton.names,
                       rec.fps, up or rec.skeleton.up)


def test_root_height_is_the_pelvis_drop_in_body_scale_units(squats):
    h = _h(squats)
    assert h.shape == (squats.n_frames,)
    assert np.median(h) == pytest.approx(0.0, abs=1e-12)
    # bd's deep squats lower the hip by more than one long bone (about 0.4 m; measured
    # range 1.66), and each take starts standing, near the highest point
    assert 1.0 < h.max() - h.min() < 2.5
    assert h[0] > h.max() - 0.1


def test_root_height_ignores_where_the_take_is_its_unit_and_the_up_axis_name(squats):
    h = _h(squats)
    P = squats.positions
    np.testing.assert_allclose(_h(squats, P + np.array([3.0, -2.0, 5.0])), h, atol=1e-9)
    np.testing.assert_allclose(_h(squats, 100.0 * P), h, atol=1e-9)  # metres -> cm
    # y up -> z up (x, y, z) -> (x, -z, y): a proper rotation, declared up "z"
    Pz = np.stack([P[..., 0], -P[..., 2], P[..., 1]], axis=-1)
    np.testing.assert_allclose(_h(squats, Pz, up="z"), h, atol=1e-9)
    np.testing.assert_allclose(_h(squats, -P, up="-y"), h, atol=1e-9)


def test_with_root_height_adds_the_weighted_column_only_when_asked(squats):
    D = np.zeros((squats.n_frames, 30))
    assert with_root_height(D, squats, RepetitionConfig()) is D
    out = with_root_height(D, squats, RepetitionConfig(root_height_weight=2.0))
    assert out.shape == (squats.n_frames, 31)
    np.testing.assert_array_equal(out[:, :30], D)
    np.testing.assert_allclose(out[:, 30], 2.0 * _h(squats))


def test_segmenter_analyses_and_aligns_on_the_root_height(squats):
    base = RepetitionSegmenter().fit(squats)
    cfg = replace(RepetitionConfig(), root_height_weight=1.0)
    seg = RepetitionSegmenter(cfg).fit(squats)
    assert seg.angles_.shape == (squats.n_frames, 31)
    assert seg.param_names_[-1] == "root_height"
    np.testing.assert_array_equal(seg.angles_[:, :30], base.angles_)
    F, cols = seg.alignment_features(seg.analysis_)
    assert 30 in cols and F.shape == (squats.n_frames, len(cols))
    assert seg.count_ == base.count_ == 4
    # an array carrying the column is analysed as the recording was
    again = RepetitionSegmenter(cfg, squats.fps).fit(seg.angles_)
    assert again.repetitions_ == seg.repetitions_
    # a column too weak to be selected is still compared by the alignment
    X = seg.angles_.copy()
    X[:, 30] *= 0.01
    weak = RepetitionSegmenter(cfg, squats.fps).fit(X)
    assert 30 not in weak.analysis_.selected
    assert 30 in weak.alignment_features(weak.analysis_)[1]


def test_a_negative_weight_is_refused():
    with pytest.raises(ParameterError, match="root_height_weight"):
        RepetitionConfig(root_height_weight=-1.0)
