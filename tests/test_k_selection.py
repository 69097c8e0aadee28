"""The number of actions found on the paper's synthetic setting (section 5.1 of Zhou et al.
2008: 4 classes, equality kernel, segments of 10-15 frames, no noise).

``git show 19427e4:benchmarks/k_selection.py`` measured K = 4 found on 10 of 10 sequences at
p_noise 0 (mean Hungarian accuracy 0.992, as given the true K) with the default criterion; the
first three of those sequences are held here."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg.config import ACAConfig
from streamseg.evaluation.metrics import matched_frame_accuracy
from streamseg.evaluation.synthetic import synthetic_sequence
from streamseg.offline.model_selection import fit_aca


@pytest.mark.parametrize("i", [0, 1, 2])
def test_k_is_found_on_the_papers_synthetic_sequences(i):
    rng = np.random.default_rng(i)  # benchmarks/aca_synthetic.py's seed at p_noise 0
    x, truth = synthetic_sequence(20, 0.0, rng)
    cfg = ACAConfig(
        kernel="equality",
        hierarchical=False,
        min_len_s=10,
        max_len_s=15,
        k_reduce=None,
        random_state=i,
    )
    fitted = fit_aca(x[:, None], cfg, fps=1.0)
    assert fitted.n_clusters_ == 4
    assert set(fitted.scores_) == set(range(2, cfg.k_max + 1))
    assert matched_frame_accuracy(fitted.labels_, truth)[0] >= 0.95
