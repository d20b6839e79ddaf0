"""The safety path's brake write: a write that fails (a late reply, a reconnect) is tried
again until the brake engages or the retry window ends, and ends in one line, never in an
exception or a traceback in the log. On simulated time."""

from __future__ import annotations

import asyncio
import logging

import pytest

from daq.clock import clock_of
from daq.plc import DeviceError
from daq.safe_state import BRAKE_RETRY_S, engage_brake

pytestmark = pytest.mark.simtime


class FlakyCoils:
    """A PLC whose coil writes fail ``failures`` times (timeouts), then succeed."""

    def __init__(self, failures: int) -> None:
        self.failures = failures
        self.connected = True
        self.written: list[tuple[str, float | bool]] = []
        self.tries = 0
        #: The time each write was given to keep trying, s.
        self.windows: list[float] = []

    async def write(self, name: str, value: float | bool, *, within_s: float) -> None:
        self.tries += 1
        self.windows.append(within_s)
        if self.tries <= self.failures:
            raise DeviceError(f"PLC write of {name!r} (coil address 0): timed out (9 tries in 1 s)")
        self.written.append((name, value))


async def test_a_brake_write_that_fails_twice_is_tried_again_and_engages(caplog):
    plc = FlakyCoils(failures=2)
    with caplog.at_level(logging.WARNING):
        failed = await engage_brake(plc, "tow_release", clock_of(asyncio.get_running_loop()))
    assert failed is None
    assert plc.written == [("tow_release", False)]
    assert all(r.exc_info is None for r in caplog.records)


async def test_a_brake_that_never_engages_is_one_line_after_the_retry_window(caplog):
    plc = FlakyCoils(failures=10**6)
    clock = clock_of(asyncio.get_running_loop())
    start = clock.now()
    with caplog.at_level(logging.WARNING):
        failed = await engage_brake(plc, "tow_release", clock)
    assert clock.now() - start == pytest.approx(BRAKE_RETRY_S, abs=0.1)
    assert failed is not None and "\n" not in failed
    assert "timed out" in failed and "brake not engaged after" in failed
    assert plc.tries > 10 and plc.written == []
    # each write keeps trying for what is left of the window, not a window of its own
    assert plc.windows[0] == pytest.approx(BRAKE_RETRY_S)
    assert plc.windows == sorted(plc.windows, reverse=True) and plc.windows[-1] < 0.1
    assert [r.exc_info for r in caplog.records] == [None] * len(caplog.records)
    assert any("tow_release" in r.getMessage() for r in caplog.records)
