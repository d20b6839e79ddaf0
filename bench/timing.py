"""Timing shared by the benchmark scripts."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence

import numpy as np


def timed(fn: Callable[[], object], repeats: int) -> dict:
    """Run ``fn`` ``repeats`` times: {median_s, max_s, cpu_median_s, repeats}.

    ``cpu_median_s`` is the process CPU time: on a loaded machine it stays near the quiet
    wall time while the wall time grows.
    """
    times, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return {
        "median_s": float(np.median(times)),
        "max_s": float(np.max(times)),
        "cpu_median_s": float(np.median(cpu)),
        "repeats": repeats,
    }


def percentile(values: Sequence[float], p: float) -> float | None:
    """The ``p``-th percentile of ``values`` (nearest rank); None when there are none."""
    if not values:
        return None
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, math.ceil(p / 100 * len(ordered)) - 1)]


def in_ms(seconds: float | None) -> float | None:
    """``seconds`` in milliseconds, rounded to the microsecond; None stays None."""
    return None if seconds is None else round(seconds * 1000, 3)
