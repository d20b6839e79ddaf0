"""Waiting on a condition in tests: poll until it holds, fail naming what never happened.

For state the test cannot subscribe to (a counter, a stat, a list another thread fills,
a job read over HTTP); returns as soon as the condition holds, so a loaded machine only
makes it slower. The only polling sleeps of the test suite live here.

No wait outlives its test: each gives up ``BUDGET_MARGIN_S`` before pytest-timeout would end
the test (``set_test_budget``, set by tests/conftest.py as the timer starts), naming what it
waited for and the last value read. Two 180 s waits of one 300 s test (a fit crawling on a
loaded host) otherwise ended in pytest-timeout's stack dump, naming nothing."""

from __future__ import annotations

import asyncio
import inspect
import math
import time
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T")

#: How long before its test's pytest-timeout a wait gives up, s: room to fail, report and
#: tear down (a service's teardown waits for the fit still running).
BUDGET_MARGIN_S = 10.0

#: How long a request a test expects to be answered may wait for its reply, s (a Modbus read,
#: a thruster frame, from a simulator in the test's own process, a thread or a `rig sim`): on a
#: loaded machine (three workers on two cores and a browser) a reply can come after 0.3 s,
#: and these tests check what is served, not how fast. The reply ends the wait, so a passing
#: test is no slower. A test that waits for a request to *fail* sets a short timeout of its
#: own.
ANSWER_S = 5.0

#: The running test's budget: (monotonic time its pytest-timeout fires, s; that timeout, s).
_budget: tuple[float, float] | None = None


def set_test_budget(ends_at: float | None, timeout_s: float = 0.0) -> tuple[float, float] | None:
    """Say when the running test's pytest-timeout fires (monotonic s; None: no test running,
    or no timeout) and its length ``timeout_s`` (s), for every wait to end before it.
    Returns the budget it replaces (``(ends_at, timeout_s)`` or None), to put back."""
    global _budget
    before, _budget = _budget, None if ends_at is None else (ends_at, timeout_s)
    return before


def _deadline(timeout_s: float) -> tuple[float, str]:
    """When a wait of ``timeout_s`` (s) starting now gives up (monotonic s), and how its
    failure says so: its own timeout, or the test's when that comes first."""
    now = time.monotonic()
    if _budget is not None and _budget[0] - BUDGET_MARGIN_S < now + timeout_s:
        ends_at, test_timeout_s = _budget
        end = max(now, ends_at - BUDGET_MARGIN_S)
        return end, (
            f"not yet when the test's {test_timeout_s:g} s timeout was {BUDGET_MARGIN_S:g} s "
            f"away ({end - now:.3g} s waited)"
        )
    return now + timeout_s, f"not within {timeout_s:g} s"


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
    ``what`` and the last value read after ``timeout_s`` (or sooner: ``set_test_budget``)."""
    deadline, late = _deadline(timeout_s)
    while not ready(value := read()):
        assert time.monotonic() < deadline, _never(what, late, value)
        time.sleep(poll_s)
    return value


async def until(
    condition: Callable[[], Any], what: str, *, timeout_s: float = 30.0, poll_s: float = 0.01
) -> Any:
    """``wait_until`` for a test on the event loop: the loop keeps running while it waits.
    ``condition`` may be a coroutine function (a read from a device, a command sent).
    Time is the loop's: simulated time in a ``simtime`` test (the test's budget is real time
    on either)."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    budget_end, late = _deadline(math.inf)
    while not (value := await _value(condition())):
        assert loop.time() < deadline, _never(what, f"not within {timeout_s:g} s", value)
        assert time.monotonic() < budget_end, _never(what, late, value)
        await asyncio.sleep(poll_s)
    return value


def _never(what: str, late: str, last: object) -> str:
    said = "" if last is None or isinstance(last, bool) else f" (last read: {last!r})"
    return f"{what}: {late}{said}"


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
