"""A wait ends before its test's pytest-timeout, naming what it waited for
(``tests.support.waiting``): a slow run then fails saying which job or state never came,
not with pytest-timeout's stack dump."""

from __future__ import annotations

import re
import time
from collections.abc import Iterator

import pytest

from tests.support.waiting import BUDGET_MARGIN_S, read_until, set_test_budget, until


@pytest.fixture
def budget_left() -> Iterator[None]:
    """The test's budget put back after the test changes it (tests/conftest.py set it)."""
    before = set_test_budget(None)
    yield
    ends_at, timeout_s = before if before is not None else (None, 0.0)
    set_test_budget(ends_at, timeout_s)


def test_a_wait_longer_than_the_test_allows_ends_before_the_timeout_naming_what(budget_left):
    set_test_budget(time.monotonic() + BUDGET_MARGIN_S + 0.1, 300.0)
    started = time.monotonic()
    with pytest.raises(AssertionError) as failed:
        read_until(lambda: {"state": "running"}, lambda job: job["state"] == "completed",
                   "job 7 completed", timeout_s=180.0)  # fmt: skip
    assert time.monotonic() - started < 60.0  # its budget's 0.1 s, not its own 180 s
    said = str(failed.value)
    assert re.fullmatch(
        r"job 7 completed: not yet when the test's 300 s timeout was 10 s away "
        r"\(0\.\d+ s waited\) \(last read: \{'state': 'running'\}\)",
        said,
    )


async def test_an_async_wait_ends_before_the_timeout_too(budget_left):
    set_test_budget(time.monotonic() + BUDGET_MARGIN_S + 0.1, 300.0)
    with pytest.raises(AssertionError, match=r"^the heartbeat: not yet when the test's 300 s"):
        await until(lambda: False, "the heartbeat", timeout_s=180.0)


def test_a_wait_inside_the_budget_keeps_its_own_timeout(budget_left):
    set_test_budget(time.monotonic() + 300.0, 300.0)
    with pytest.raises(AssertionError) as failed:
        read_until(lambda: 3, lambda n: n > 3, "four samples", timeout_s=0.05)
    assert str(failed.value) == "four samples: not within 0.05 s (last read: 3)"


@pytest.mark.timeout(BUDGET_MARGIN_S + 0.5)
def test_pytest_timeouts_timer_sets_the_budget():
    # tests/conftest.py hears the timer start: the wait gives up 0.5 s in, before it fires
    late = r"^the job: not yet when the test's 10\.5 s timeout was 10 s away"
    with pytest.raises(AssertionError, match=late):
        read_until(lambda: None, bool, "the job", timeout_s=60.0)
