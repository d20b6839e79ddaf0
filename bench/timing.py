"""Timing shared by the benchmark scripts."""

from __future__ import annotations

import time
from collections.abc import Callable

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
