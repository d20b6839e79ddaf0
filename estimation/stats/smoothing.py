"""Savitzky–Golay filtering as one fixed linear operator: SciPy's coefficients and edges.

``scipy.signal.savgol_filter(mode="interp")`` convolves the interior with
``savgol_coeffs`` and, on every call, fits a polynomial to each end's window by least
squares (``polyfit``, twice per call): ~0.5 ms per record and derivative, a quarter of a
tow search's CPU once its integrator was compiled (the force residual and its noise floor
filter every run several times per fit). The filter is linear in the samples, so each end's
rows are fixed for a window, order, derivative and step: they are computed once here, by
filtering the identity with ``savgol_filter`` itself, and applied as a matrix product; the
interior is the same convolution. Equal to ``savgol_filter`` to rounding
(``tests/estimation/test_smoothing.py``).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.signal import savgol_coeffs, savgol_filter

_KEPT = 32  # (window, order, derivative, step) operators in use at once: a few per estimate


@lru_cache(maxsize=_KEPT)
def _operator(window: int, order: int, deriv: int, delta: float):
    """Convolution coefficients and the rows of the two ends (half × window each)."""
    coeffs = savgol_coeffs(window, order, deriv=deriv, delta=delta)
    ends = savgol_filter(np.eye(window), window, order, deriv=deriv, delta=delta, axis=0)
    half = window // 2
    head, tail = ends[:half].copy(), ends[window - half :].copy()
    for a in (coeffs, head, tail):
        a.flags.writeable = False
    return coeffs, head, tail


def savgol(y: np.ndarray, window: int, order: int, deriv: int = 0, delta: float = 1.0):
    """``savgol_filter(y, window, order, deriv=deriv, delta=delta)`` (mode "interp") of a
    1-D array: the filtered samples (derivative ``deriv`` per ``delta``, y's unit per s^deriv
    when ``delta`` is the sample step in s)."""
    y = np.asarray(y, dtype=float)
    if y.ndim != 1 or y.size <= window:  # nothing between the ends: SciPy's own path
        return savgol_filter(y, window, order, deriv=deriv, delta=delta)
    coeffs, head, tail = _operator(int(window), int(order), int(deriv), float(delta))
    half = window // 2
    out = np.empty_like(y)
    out[half : y.size - half] = np.convolve(y, coeffs, mode="valid")
    out[:half] = head @ y[:window]
    out[y.size - half :] = tail @ y[y.size - window :]
    return out
