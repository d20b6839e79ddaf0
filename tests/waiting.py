"""Waiting on a condition in tests: poll until it holds, fail naming what never happened.

For state the test cannot subscribe to (a counter, a stat, a list another thread fills);
returns as soon as the condition holds, so a loaded machine only makes it slower."""

from __future__ import annotations

import asyncio
import inspect
import time
from collections.abc import Callable
from typing import Any


def wait_until(
    condition: Callable[[], object], what: str, *, timeout_s: float = 30.0, poll_s: float = 0.01
) -> None:
    """Block until ``condition()`` is true; AssertionError naming ``what`` after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"{what}: not within {timeout_s:g} s"
        time.sleep(poll_s)


async def until(
    condition: Callable[[], object], what: str, *, timeout_s: float = 30.0, poll_s: float = 0.01
) -> None:
    """``wait_until`` for a test on the event loop: the loop keeps running while it waits.
    ``condition`` may be a coroutine function (a read from a device)."""
    deadline = time.monotonic() + timeout_s
    while not await _value(condition()):
        assert time.monotonic() < deadline, f"{what}: not within {timeout_s:g} s"
        await asyncio.sleep(poll_s)


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
