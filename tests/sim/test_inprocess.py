"""The PLC in process: a request interleaves with the loop's other tasks as a request
through ``asyncio.wait_for`` did (served one loop pass after it is sent, its reply taken two
passes later), whether the emulation takes those passes or skips them while alone."""

from __future__ import annotations

import asyncio

import pytest

from daq.config import load_rig
from daq.sim.inprocess import InProcessModbus, open_inprocess_rig
from daq.sim.simtime import SimClock


async def _interleaving(others: int, passes: int) -> list[str]:
    clock = SimClock.of_running_loop()
    rig = open_inprocess_rig(load_rig(), None, clock)
    modbus = InProcessModbus(rig.plc, rig.plc.rig.modbus.timeout_s)
    await modbus.connect()
    order: list[str] = []
    serve = rig.plc.serve

    async def traced(*request: object) -> object:
        order.append("served")
        return await serve(*request)  # type: ignore[arg-type]

    rig.plc.serve = traced  # type: ignore[method-assign]

    async def other(name: str) -> None:
        for i in range(passes):
            order.append(f"{name}{i}")
            await asyncio.sleep(0)

    tasks = [asyncio.ensure_future(other(chr(ord("a") + n))) for n in range(others)]
    started = clock.now()
    reply = await modbus.read_discrete_inputs(0, count=2, device_id=1)
    order.append("reply")
    await asyncio.gather(*tasks)
    assert not reply.isError() and clock.now() == started
    return order


@pytest.mark.parametrize(
    ("others", "passes", "expected"),
    [
        (0, 0, ["served", "reply"]),
        (1, 4, ["a0", "served", "a1", "a2", "reply", "a3"]),
        (1, 1, ["a0", "served", "reply"]),  # alone after the first pass
        (2, 2, ["a0", "b0", "served", "a1", "b1", "reply"]),
    ],
)
def test_a_request_takes_the_loop_passes_of_a_wait_for(others, passes, expected):
    assert SimClock.run(_interleaving(others, passes)) == expected
