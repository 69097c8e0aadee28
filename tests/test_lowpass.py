"""The repetition tracker's low-pass coefficients are SciPy's, to the bit, without importing
``scipy.signal`` (``streamseg.online.lowpass``)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import butter, sosfilt_zi

from streamseg.online.lowpass import butter2_sos, sos_initial_state


@pytest.mark.parametrize("fs", [1.0, 10.0, 15.0, 25.0, 30.0, 50.0, 60.0, 100.0, 120.0, 240.0])
def test_butterworth_section_and_its_rest_state_are_scipys(fs):
    rng = np.random.default_rng(int(fs))
    for cutoff in [0.45 * fs, *rng.uniform(0.01 * fs, 0.45 * fs, 60)]:
        want = butter(2, cutoff, fs=fs, output="sos")
        got = butter2_sos(cutoff, fs)
        assert got.dtype == want.dtype and np.array_equal(got, want), cutoff
        assert np.array_equal(sos_initial_state(got), sosfilt_zi(want)), cutoff


@pytest.mark.parametrize("cutoff", [0.0, -1.0, 60.0, float("nan")])
def test_a_cutoff_outside_the_band_is_refused(cutoff):
    with pytest.raises(ValueError, match="0 < cutoff < fs / 2"):
        butter2_sos(cutoff, 120.0)
