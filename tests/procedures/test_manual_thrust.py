"""Manual thrust on the simulated stand (in process, simulated time): whatever ends it early
— the rig's own emergency-stop button, the thruster link lost — the controller's outputs are
zero and it is disarmed, the brake engaged, and the run stored aborted with the reason."""

from __future__ import annotations

import asyncio

import pytest

from daq.procedures.manual_thrust import run_manual_thrust
from daq.procedures.requests import manual_thrust_parameters
from daq.store.run_events import RunAction
from tests.procedures.conftest import until_thrust_on

pytestmark = pytest.mark.simtime

LONG = {"thruster": 1, "command": 0.6, "duration_s": 30.0}


def _left_safe(session, store, run_id: str) -> None:
    emulator = session.sim.thrusters
    assert emulator.outputs == [0.0, 0.0] and emulator.state in ("DISARMED", "WDT")
    assert not session.armed
    safe = [
        e.data for e in store.events(run_id) if (e.data or {}).get("action") == RunAction.SAFE_STATE
    ]
    assert safe and safe[-1]["thrusters_zero"] is True
    assert "tow_release" in safe[-1]["brakes_engaged"]


async def test_the_rigs_emergency_stop_button_mid_manual_run_zeroes_and_brakes(session, store):
    task = asyncio.create_task(
        run_manual_thrust(session, manual_thrust_parameters(LONG, session.rig))
    )
    await until_thrust_on(session, timeout_s=10)
    session.sim.plant.press_estop(True)
    try:
        outcome = await asyncio.wait_for(task, 10)
    finally:
        session.sim.plant.press_estop(False)
    assert outcome.status == "aborted" and outcome.reason == "emergency stop", outcome
    _left_safe(session, store, outcome.run_id)


async def test_a_lost_thruster_link_mid_manual_run_ends_it_at_zero(session, store):
    task = asyncio.create_task(
        run_manual_thrust(session, manual_thrust_parameters(LONG, session.rig))
    )
    await until_thrust_on(session, timeout_s=10)
    emulator = session.sim.thrusters
    emulator.silent = True  # it hears nothing (its watchdog zeroes it), and says nothing
    outcome = await asyncio.wait_for(task, 10)
    assert emulator.outputs == [0.0, 0.0] and emulator.stats.watchdog_trips == 1
    emulator.silent = False
    assert outcome.status == "aborted" and outcome.reason.startswith("thruster link lost"), outcome
    assert store.get_run(outcome.run_id).reason == outcome.reason
    events = store.events(outcome.run_id)
    safe = [e.data for e in events if (e.data or {}).get("action") == RunAction.SAFE_STATE]
    assert "tow_release" in safe[-1]["brakes_engaged"]
