"""The repetition tracker's low-pass filter: a second-order Butterworth section and its
steady-state initial conditions, without importing ``scipy.signal``.

``scipy.signal`` imports most of SciPy (``scipy.stats``, ``scipy.optimize``,
``scipy.interpolate``, ...: about half a second of ``streamseg segment --method rep``'s start
on this project's machine) for two formulas of a few lines. These are its own steps, in its
order (``butter(2, cutoff, fs=fs, output="sos")``: analogue prototype, frequency warping,
bilinear transform, one section; ``sosfilt_zi``), so the coefficients are the same to the bit
(``tests/test_lowpass.py`` checks them against SciPy).
"""

from __future__ import annotations

import numpy as np


def butter2_sos(cutoff: float, fs: float) -> np.ndarray:
    """``scipy.signal.butter(2, cutoff, fs=fs, output="sos")``: (1, 6) float64.

    ``cutoff`` in Hz, ``0 < cutoff < fs / 2``.
    """
    if not (np.isfinite(cutoff) and np.isfinite(fs) and 0 < cutoff < fs / 2):
        raise ValueError(
            f"cutoff={cutoff!r} Hz is invalid at fs={fs!r} Hz: expected 0 < cutoff < fs / 2"
        )
    wn = 2 * cutoff / fs  # normalized to Nyquist
    p = -np.exp(1j * np.pi * np.arange(-1, 2, 2) / 4)  # analogue prototype poles, order 2
    warped = 2 * 2.0 * np.tan(np.pi * wn / 2.0)  # pre-warped, at fs = 2
    p = warped * p
    k = warped**2
    fs2 = 2.0 * 2.0
    p_z = (fs2 + p) / (fs2 - p)  # bilinear transform; both zeros at -1
    k_z = k * np.real(1.0 / np.prod(fs2 - p))
    b = k_z * np.poly(-np.ones(2))
    a = np.real(np.poly(p_z))
    return np.concatenate([b, a])[None, :]


def sos_initial_state(sos: np.ndarray) -> np.ndarray:
    """``scipy.signal.sosfilt_zi(sos)``: (n_sections, 2), the state of a filter at rest on a
    unit step (scale it by the first sample)."""
    sos = np.asarray(sos, dtype=np.float64)
    zi = np.empty((sos.shape[0], 2))
    scale = 1.0
    for s in range(sos.shape[0]):
        b, a = sos[s, :3], sos[s, 3:]
        if a[0] != 1.0:
            b, a = b / a[0], a / a[0]
        companion_t = np.array([[-a[1] / (1.0 * a[0]), 1.0], [-a[2] / (1.0 * a[0]), 0.0]])
        zi[s] = scale * np.linalg.solve(np.eye(2) - companion_t, b[1:] - a[1:] * b[0])
        scale *= np.sum(b) / np.sum(a)
    return zi
