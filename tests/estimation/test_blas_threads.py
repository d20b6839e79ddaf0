"""The estimator's one-BLAS-thread limit: set for the call, kept by a nested call, restored."""

from __future__ import annotations

import numpy  # noqa: F401  (loads its BLAS)
import pytest
import scipy.linalg  # noqa: F401  (loads its own BLAS)
from threadpoolctl import threadpool_info, threadpool_limits

from estimation.blas_threads import one_blas_thread


def _blas_threads() -> list[int]:
    return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]


def test_the_limit_holds_inside_nested_calls_and_is_restored_after() -> None:
    seen: dict[str, list[int]] = {}

    @one_blas_thread
    def inner() -> None:
        seen["inner"] = _blas_threads()

    @one_blas_thread
    def outer() -> None:
        seen["before_inner"] = _blas_threads()
        inner()
        seen["after_inner"] = _blas_threads()

    with threadpool_limits(limits=2, user_api="blas"):
        assert _blas_threads() and set(_blas_threads()) == {2}
        outer()
        assert set(_blas_threads()) == {2}
    assert set(seen["before_inner"]) == {1}
    assert set(seen["inner"]) == {1}
    assert set(seen["after_inner"]) == {1}  # the inner call did not restore its caller's


def test_the_limit_is_restored_when_the_call_raises() -> None:
    @one_blas_thread
    def fails() -> None:
        raise ValueError("boom")

    with threadpool_limits(limits=2, user_api="blas"):
        with pytest.raises(ValueError):
            fails()
        assert set(_blas_threads()) == {2}
