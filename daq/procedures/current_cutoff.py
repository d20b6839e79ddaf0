"""The thrusters' current cut-off: the rig file's ``thrusters.max_current_a`` stops a test
whose thrusters draw more (the controller's telemetry, read while the run lasts: the
run's logged telemetry when fresh, ``daq.thruster_supervisor``, else a query)."""

from __future__ import annotations

import asyncio
from typing import Any

from daq.session import RigSession
from thrusters.driver import ThrusterError


async def current_over_limit(session: RigSession) -> tuple[str, dict[str, Any]]:
    """Read the controller's telemetry every ``thrusters.current_check_s`` while the run
    lasts; return (reason, event data) once a thruster draws more than the rig file's
    ``thrusters.max_current_a``. Never returns without such a cut-off."""
    port = session.rig.thruster_port()
    limit = port.max_current_a
    if limit is None:
        await asyncio.Event().wait()  # no cut-off declared: wait to be cancelled
    assert limit is not None
    while True:
        await asyncio.sleep(port.current_check_s)  # the cut-off's own polling period
        # The telemetry the run logs every tick when it is fresh; else ask the controller.
        status = session.telemetry.fresh() if session.telemetry is not None else None
        if status is None:
            try:
                status = await session.live_thrusters.query()
            except ThrusterError:  # a lost link is the driver's own fault, reported there
                continue
        over = [(i, a) for i, a in enumerate(status.current_a) if a > limit]
        if over:
            i, amps = max(over, key=lambda pair: pair[1])
            reason = (
                f"thruster {i + 1} drew {amps:.3g} A, over the safety cut-off "
                f"thrusters.max_current_a = {limit:g} A: thrusters zeroed"
            )
            data = {"current_a": list(status.current_a), "max_current_a": limit}
            return reason, data
