"""What a fit reads off a record, once per record content: its smoothed derivatives and its
encoder step. A search fits the same records a dozen times; each reading is kept for the
``KEPT`` most recent records (by their bytes), read-only.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from estimation.stats.diagnostics import smoothed_derivatives
from estimation.stats.quantization import encoder_step

KEPT = 8  # records of one estimate; each entry holds its t and x (as keys)


def derivatives(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ẋ and ẍ at the samples: 7-point Savitzky–Golay on a uniform resampling (read-only).

    A fit reads a record's derivatives for its start, its scales and each candidate's
    typical size (≈ 9 times per ``estimate_decay``; the filter's edge fits cost 1–2 ms):
    they are computed once per record content (``KEPT`` most recent)."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    return _derivatives(t.tobytes(), x.tobytes())


@lru_cache(maxsize=KEPT)
def _derivatives(t_bytes: bytes, x_bytes: bytes) -> tuple[np.ndarray, np.ndarray]:
    d1, d2 = smoothed_derivatives(np.frombuffer(t_bytes), np.frombuffer(x_bytes))
    d1.flags.writeable = d2.flags.writeable = False
    return d1, d2


def record_step(x: np.ndarray) -> float:
    """The record's encoder step (``estimation.stats.quantization.encoder_step``, m or rad):
    every fit of a search reads it for its quantization σ (0.1–0.2 ms each on the published
    decays), so it is read once per record content (``KEPT`` most recent)."""
    return _record_step(np.asarray(x, dtype=float).tobytes())


@lru_cache(maxsize=KEPT)
def _record_step(x_bytes: bytes) -> float:
    return encoder_step(np.frombuffer(x_bytes))
