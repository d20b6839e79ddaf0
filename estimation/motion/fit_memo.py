"""The last few results of a costly function of a fit, by the identity of its inputs.

An estimate asks several times for the same thing of the same fit: its sensitivity matrix
(identifiability, correlations, predicted steps), its force residual (the unexplained
verdict, the result's per-run RMS). ``Recent`` keeps the last ``size`` results with the very
input objects they were computed from: holding them means no identity is reused while an
entry lives, so a hit is the same computation, not a look-alike. Thread-safe (the service
estimates on a thread pool); results are shared, so callers must not modify them.
"""

from __future__ import annotations

from collections.abc import Callable
from threading import Lock
from typing import Any, Generic, TypeVar

R = TypeVar("R")

#: Inputs compared by value (names, counts, tuples of them); every other by identity.
_BY_VALUE = (str, int, tuple)


class Recent(Generic[R]):
    """``get(inputs, compute)``: ``compute()``, or its result for the same input objects
    (compared with ``is``, element by element) among the last ``size``."""

    def __init__(self, size: int = 4) -> None:
        self.size = size
        self._entries: list[tuple[tuple[Any, ...], R]] = []
        self._lock = Lock()

    def get(self, inputs: tuple[Any, ...], compute: Callable[[], R]) -> R:
        with self._lock:
            for held, result in self._entries:
                if len(held) == len(inputs) and all(
                    a is b or (isinstance(a, _BY_VALUE) and a == b)
                    for a, b in zip(held, inputs, strict=True)
                ):
                    return result
        result = compute()
        with self._lock:
            self._entries.insert(0, (inputs, result))
            del self._entries[self.size :]
        return result
