"""Waiting on a condition in tests: poll until it holds, fail naming what never happened.

For state the test cannot subscribe to (a counter, a stat, a list another thread fills,
a job read over HTTP); returns as soon as the condition holds, so a loaded machine only
makes it slower. The only polling sleeps of the test suite live here."""

from __future__ import annotations

import asyncio
import inspect
import time
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T")


def wait_until(
    condition: Callable[[], T], what: str, *, timeout_s: float = 30.0, poll_s: float = 0.01
) -> T:
    """Block until ``condition()`` is truthy and return that value; AssertionError naming
    ``what`` after ``timeout_s``. ``condition`` may assert to fail at once (a process
    that exited, a job that ended first)."""
    return read_until(condition, bool, what, timeout_s=timeout_s, poll_s=poll_s)


def read_until(
    read: Callable[[], T],
    ready: Callable[[T], object],
    what: str,
    *,
    timeout_s: float = 30.0,
    poll_s: float = 0.01,
) -> T:
    """Block until ``ready(read())`` and return the value read; AssertionError naming
    ``what`` and the last value read after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not ready(value := read()):
        assert time.monotonic() < deadline, _never(what, timeout_s, value)
        time.sleep(poll_s)
    return value


async def until(
    condition: Callable[[], Any], what: str, *, timeout_s: float = 30.0, poll_s: float = 0.01
) -> Any:
    """``wait_until`` for a test on the event loop: the loop keeps running while it waits.
    ``condition`` may be a coroutine function (a read from a device, a command sent).
    Time is the loop's: simulated time in a ``simtime`` test."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while not (value := await _value(condition())):
        assert loop.time() < deadline, _never(what, timeout_s, value)
        await asyncio.sleep(poll_s)
    return value


def _never(what: str, timeout_s: float, last: object) -> str:
    said = "" if last is None or isinstance(last, bool) else f" (last read: {last!r})"
    return f"{what}: not within {timeout_s:g} s{said}"


async def _value(result: object) -> object:
    return await result if inspect.isawaitable(result) else result


async def next_samples(acquisition: Any, count: int, *, timeout_s: float = 10.0) -> list[Any]:
    """The next ``count`` samples the acquisition clock takes (``Acquisition.subscribe``):
    to watch something over clock ticks rather than over a guessed wall-clock time."""
    queue = acquisition.subscribe(maxsize=count, name="test-next-samples")
    try:
        return [await asyncio.wait_for(queue.get(), timeout_s) for _ in range(count)]
    finally:
        acquisition.unsubscribe(queue)
