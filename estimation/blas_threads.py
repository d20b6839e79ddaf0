"""One BLAS thread for the estimator's small least-squares problems.

The fits factor matrices of a few hundred rows by a few columns. OpenBLAS's worker threads
spin while they wait for such tiny jobs, which costs CPU on a 2-core rig PC without making
the fit faster (``bench/estimation_speed.py``: the outside-library search 1.15 s CPU with
the default threads, 0.79 s with one). ``threadpoolctl`` sets the limit for the call and
restores it after, so the rest of the process keeps its threads.

The BLAS libraries are found once per process (``_controller``): ``threadpool_limits``
scans every loaded shared library on each call, 1.6 ms of CPU here, against ~20 ms for a
whole clean free-decay search; an estimate inside another (a pendulum's decay search) keeps
the limit its caller set, and the last call to leave restores the threads.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from functools import cache, wraps
from typing import Any, ParamSpec, TypeVar

from threadpoolctl import ThreadpoolController

P = ParamSpec("P")
R = TypeVar("R")

_lock = threading.Lock()
_depth = 0
_limited: Any = None  # the limit in force while a call runs (its restore undoes it)


@cache
def _controller() -> ThreadpoolController:
    """The process's BLAS libraries: numpy's and scipy's (imported first, so its own
    OpenBLAS is loaded and found; the fits use both)."""
    import scipy.linalg  # noqa: F401

    return ThreadpoolController()


def _enter() -> None:
    global _depth, _limited
    with _lock:
        if _depth == 0:
            _limited = _controller().limit(limits=1, user_api="blas")
        _depth += 1


def _leave() -> None:
    global _depth, _limited
    with _lock:
        _depth -= 1
        if _depth == 0:
            _limited.restore_original_limits()
            _limited = None


def one_blas_thread(fn: Callable[P, R]) -> Callable[P, R]:
    """Run ``fn`` with BLAS limited to one thread (restored afterwards)."""

    @wraps(fn)
    def limited(*args: P.args, **kwargs: P.kwargs) -> R:
        _enter()
        try:
            return fn(*args, **kwargs)
        finally:
            _leave()

    return limited
