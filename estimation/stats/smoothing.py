"""Savitzky–Golay filtering as one fixed linear operator, and a running median: SciPy's
filters, in NumPy.

``scipy.signal.savgol_filter(mode="interp")`` convolves the interior with
``savgol_coeffs`` and, on every call, fits a polynomial to each end's window by least
squares (``polyfit``, twice per call): ~0.5 ms per record and derivative, a quarter of a
tow search's CPU once its integrator was compiled (the force residual and its noise floor
filter every run several times per fit). The filter is linear in the samples: sample i of
a window of w is the derivative at i of the degree-``order`` polynomial fitted by least
squares to the window, i.e. row i of the w × w operator D·V⁺ (V the Vandermonde matrix of
the window's positions, D the derivative of its powers at each position; positions scaled
to [−1, 1] about the window's middle, which keeps V well conditioned). The middle row is
the interior's convolution (SciPy's ``savgol_coeffs``), the first and last w // 2 rows are
the two ends (SciPy's edge fits). It is built once per window, order, derivative and step,
in NumPy: importing ``scipy.signal`` costs ~1 s of CPU (it imports ``scipy.stats``), more
than the search it serves. Equal to ``savgol_filter`` to rounding, nearer the exact
derivative than it at the ends of long windows (``tests/estimation/stats/test_smoothing.py``).

``running_median`` is ``scipy.ndimage.median_filter(mode="nearest")`` of finite samples, to
the bit (a median of an odd count is one of the samples): the window finder's spike and
noise checks load every tow and spin with it, and importing ``scipy.ndimage`` cost ~0.07 s
of CPU per ``rig estimate`` (its import builds the docstrings of its array-API wrappers).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

_KEPT = 32  # (window, order, derivative, step) operators in use at once: a few per estimate


@lru_cache(maxsize=_KEPT)
def _operator(window: int, order: int, deriv: int, delta: float):
    """Convolution coefficients and the rows of the two ends (half × window each)."""
    half = window // 2
    at = (np.arange(window, dtype=float) - half) / max(half, 1)  # in [−1, 1]: well conditioned
    powers = np.arange(order + 1)
    fit = np.linalg.pinv(at[:, None] ** powers)  # (order + 1, window): samples → coefficients
    falling = np.array([math.perm(k, deriv) for k in powers], dtype=float)  # d^m u^k / du^m
    shifted = np.clip(powers - deriv, 0, None)
    rows = (falling * at[:, None] ** shifted) @ fit / (delta * max(half, 1)) ** deriv
    coeffs = rows[half][::-1].copy()  # np.convolve flips its kernel
    head, tail = rows[:half].copy(), rows[window - half :].copy()
    for a in (coeffs, head, tail):
        a.flags.writeable = False
    return coeffs, head, tail


def savgol(y: np.ndarray, window: int, order: int, deriv: int = 0, delta: float = 1.0):
    """``savgol_filter(y, window, order, deriv=deriv, delta=delta)`` (mode "interp") of a
    1-D array: the filtered samples (derivative ``deriv`` per ``delta``, y's unit per s^deriv
    when ``delta`` is the sample step in s)."""
    y = np.asarray(y, dtype=float)
    if y.ndim != 1 or y.size < window or window % 2 == 0 or order >= window:
        from scipy.signal import savgol_filter  # SciPy's own path, and its errors

        return savgol_filter(y, window, order, deriv=deriv, delta=delta)
    coeffs, head, tail = _operator(int(window), int(order), int(deriv), float(delta))
    half = window // 2
    out = np.empty_like(y)
    out[half : y.size - half] = np.convolve(y, coeffs, mode="valid")
    out[:half] = head @ y[:window]
    out[y.size - half :] = tail @ y[y.size - window :]
    return out


def running_median(x: np.ndarray, size: int) -> np.ndarray:
    """``scipy.ndimage.median_filter(x, size=size, mode="nearest")`` of a 1-D array (x's
    unit): each sample's median over the ``size`` samples centred on it (odd ``size``), the
    ends repeated beyond the record. Samples that are not all finite (SciPy orders NaN its
    own way) and even sizes take SciPy's own filter."""
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or size % 2 == 0 or size < 1 or not np.all(np.isfinite(x)):
        from scipy.ndimage import median_filter  # SciPy's own path, and its errors

        return median_filter(x, size=size, mode="nearest")
    if x.size == 0:
        return x.copy()
    padded = np.pad(x, size // 2, mode="edge")
    return np.median(np.lib.stride_tricks.sliding_window_view(padded, size), axis=1)
