"""One BLAS thread for the estimator's small least-squares problems.

The fits factor matrices of a few hundred rows by a few columns. OpenBLAS's worker threads
spin while they wait for such tiny jobs, which costs CPU on a 2-core rig PC without making
the fit faster (``bench/estimation_speed.py``: the outside-library search 1.15 s CPU with
the default threads, 0.79 s with one). ``threadpoolctl`` sets the limit for the call and
restores it after, so the rest of the process keeps its threads.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import wraps
from typing import ParamSpec, TypeVar

from threadpoolctl import threadpool_limits

P = ParamSpec("P")
R = TypeVar("R")


def one_blas_thread(fn: Callable[P, R]) -> Callable[P, R]:
    """Run ``fn`` with BLAS limited to one thread (restored afterwards)."""

    @wraps(fn)
    def limited(*args: P.args, **kwargs: P.kwargs) -> R:
        with threadpool_limits(limits=1, user_api="blas"):
            return fn(*args, **kwargs)

    return limited
