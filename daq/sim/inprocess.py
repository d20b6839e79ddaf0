"""The simulated rig in process: the PLC client and the thruster driver talk to the
simulated PLC and thruster controller by function call instead of over a socket or a pty.

What stays the same as on the wire: the real ``PlcClient`` (block reads planned from the
rig file's register map, word order, scaling, counter unwrapping, STALE and ERROR flags)
asks ``SimulatedPLC.serve`` for the same register words a Modbus server would send; the
real ``ThrusterDriver`` (slew limit, heartbeat, link supervision, zero-on-exit) sends the
same frames to ``ThrusterControllerEmulator.exchange`` (CRC, sequence numbers, watchdog).
What is left out: framing bytes, transaction ids, reconnects and the time a request
spends on the line (a reply comes back at the same simulated instant). Fault switches
act as a client sees them: ``faults.drop``/``corrupt`` cost ``modbus.timeout_s`` and fail,
``faults.delay_s`` over the timeout fails, a silent thruster controller gives no reply
(the driver waits its reply timeout on the loop).

``open_inprocess_rig(rig, scenario, clock)`` gives the plant, the simulated devices and
connected clients on ``clock`` (a ``daq.sim.simtime.SimClock`` in tests).
"""

from __future__ import annotations

import asyncio
import functools
import inspect
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

from pymodbus.exceptions import ModbusException

from daq.clock import Clock
from daq.config import RigConfig
from daq.plc import PlcClient
from daq.sim.plant import Plant
from daq.sim.plc_server import SimulatedPLC
from daq.sim.scenario import Scenario
from daq.sim.simtime import SimTimeLoop
from daq.sim.simulated_rig import SimulatedRig, takes_one_argument
from thrusters.driver import ThrusterDriver
from thrusters.emulator import ThrusterControllerEmulator
from thrusters.inprocess_link import InProcessLink

_BITS = {1: "coil", 2: "discrete", 5: "coil", 15: "coil"}


@dataclass
class Response:
    """What a pymodbus client returns: words or bits, or an exception code."""

    registers: list[int] = field(default_factory=list)
    bits: list[bool] = field(default_factory=list)
    exception: object = None

    def isError(self) -> bool:  # pymodbus spells it so
        return self.exception is not None


class InProcessModbus:
    """A pymodbus-client-shaped front of a ``SimulatedPLC`` (the PLC client's transport)."""

    def __init__(self, plc: SimulatedPLC, timeout_s: float) -> None:
        self.plc = plc
        self.timeout_s = timeout_s
        self.connected = False
        #: Words and bits as last served or written (a channel the plant does not model
        #: keeps what was written, as in the server's datastore).
        self._words: dict[int, dict[int, int]] = {3: {}, 4: {}}
        self._bits: dict[str, dict[int, bool]] = {"coil": {}, "discrete": {}}

    async def connect(self) -> bool:
        self.connected = True
        return True

    def close(self) -> None:
        self.connected = False

    async def read_coils(self, address: int, *, count: int, device_id: int) -> Response:
        return await self._bit_request(1, address, count, None)

    async def read_discrete_inputs(self, address: int, *, count: int, device_id: int) -> Response:
        return await self._bit_request(2, address, count, None)

    async def read_holding_registers(self, address: int, *, count: int, device_id: int) -> Response:
        return await self._word_request(3, address, count, None)

    async def read_input_registers(self, address: int, *, count: int, device_id: int) -> Response:
        return await self._word_request(4, address, count, None)

    async def write_coil(self, address: int, value: bool, *, device_id: int) -> Response:
        return await self._bit_request(5, address, 1, [bool(value)])

    async def write_register(self, address: int, value: int, *, device_id: int) -> Response:
        return await self._word_request(6, address, 1, [value])

    async def write_registers(self, address: int, values: list[int], *, device_id: int) -> Response:
        return await self._word_request(16, address, len(values), list(values))

    async def _bit_request(
        self, fc: int, address: int, count: int, values: list[bool] | None
    ) -> Response:
        image = self._bits[_BITS[fc]]
        words = [0] * ((address + count) // 16 + 1)
        for a, bit in image.items():
            if bit and a < 16 * len(words):
                words[a // 16] |= 1 << (a % 16)
        exc = await self._serve(fc, 0, address, count, words, values)
        if exc is not None:
            return Response(exception=exc)
        if values is not None:
            image.update({address + i: bool(v) for i, v in enumerate(values)})
            return Response(bits=list(values))
        bits = [bool(words[a // 16] >> (a % 16) & 1) for a in range(address, address + count)]
        image.update({address + i: b for i, b in enumerate(bits)})
        return Response(bits=bits)

    async def _word_request(
        self, fc: int, address: int, count: int, values: list[int] | None
    ) -> Response:
        image = self._words[4 if fc == 4 else 3]
        words = [image.get(a, 0) for a in range(address, address + count)]
        exc = await self._serve(fc, address, address, count, words, values)
        if exc is not None:
            return Response(exception=exc)
        if values is not None:
            words = list(values)
        image.update({address + i: w for i, w in enumerate(words)})
        return Response(registers=words)

    async def _serve(
        self,
        fc: int,
        start: int,
        address: int,
        count: int,
        words: list[int],
        values: list[int] | list[bool] | None,
    ) -> object:
        if not self.connected:
            raise ConnectionError("in-process PLC: not connected")
        faults = self.plc.faults
        serving = functools.partial(self.plc.serve, fc, start, address, count, words, values)
        if self.plc.answers_at_once:
            # What ``wait_for`` below does when the PLC answers at once, without its task,
            # future and timer: the request is served one loop pass later and the reply
            # taken two passes after that, so other tasks interleave exactly as there.
            await _loop_pass()
            exc = await self._serve_now(serving)
            await _loop_pass()
            await _loop_pass()
        else:
            try:
                exc = await asyncio.wait_for(serving(), self.timeout_s)
            except TimeoutError:
                raise TimeoutError(f"no response within {self.timeout_s} s") from None
        if faults.take_drop():
            await asyncio.sleep(self.timeout_s)
            raise TimeoutError(f"no response within {self.timeout_s} s")
        if faults.corrupt:
            await asyncio.sleep(self.timeout_s)
            raise ModbusException("response could not be decoded")
        return exc

    async def _serve_now(self, serving: Callable[[], Awaitable[object]]) -> object:
        """Serve in this task; under the client's timeout if a fault was switched on since
        the request was sent (the PLC may wait now)."""
        if self.plc.answers_at_once:
            return await serving()
        try:
            async with asyncio.timeout(self.timeout_s):
                return await serving()
        except TimeoutError:
            raise TimeoutError(f"no response within {self.timeout_s} s") from None


async def _loop_pass() -> None:
    """Let the loop run one pass, unless on simulated time nothing else could run in it
    (``SimTimeLoop.alone``): then the pass would change nothing and is skipped."""
    loop = asyncio.get_running_loop()
    if not (isinstance(loop, SimTimeLoop) and loop.alone()):
        await asyncio.sleep(0)


@dataclass
class InProcessRig:
    """The plant, the simulated devices and the host's clients on one clock (a
    ``daq.device_protocols.RigDevices``; a session keeps it as ``session.sim``)."""

    plant: Plant
    plc: SimulatedPLC
    thrusters: ThrusterControllerEmulator | None
    plc_client: PlcClient
    driver: ThrusterDriver | None

    def call(self, fn: Callable[..., Any], *args: Any) -> Any:
        """``fn(*args)`` (a one-parameter ``fn`` without arguments gets this rig), as
        ``SimulatedRigThread.call`` does on its thread; here on the caller's loop."""
        if not args and takes_one_argument(fn):
            args = (self,)
        result = fn(*args)
        if inspect.isawaitable(result):
            raise TypeError("in process, await the simulator's coroutines directly")
        return result

    def close(self) -> None:
        """Thrusters to zero and both brakes on, as the simulator does when it stops."""
        self.plant.set_commands([0.0] * self.plant.thruster_port.count)
        self.plant.engage_tow_brake()
        self.plant.engage_spin_brake()


def open_inprocess_rig(rig: RigConfig, scenario: Scenario | None, clock: Clock) -> InProcessRig:
    """The simulated rig of ``rig`` wired in process on ``clock`` (clients not yet opened:
    ``await plc_client.connect()``, ``await driver.open()``)."""
    sim = SimulatedRig(rig, scenario, clock=clock.now)
    sim.plant.advance_to(clock.now())
    timeout_s = rig.modbus.timeout_s
    client = PlcClient(rig, clock=clock, transport=lambda: InProcessModbus(sim.plc, timeout_s))
    driver = None
    if sim.thrusters is not None and rig.thrusters is not None:
        link = InProcessLink(sim.thrusters, rig.thrusters.ack_timeout_s, clock=clock.now)
        driver = ThrusterDriver(rig.thrusters, rig.limits, clock=clock.now, link=link)
    return InProcessRig(sim.plant, sim.plc, sim.thrusters, client, driver)
