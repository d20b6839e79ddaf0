"""The simulated PLC: a pymodbus server that serves the plant through the register map.

The register blocks are built from the rig file (``daq.registers`` encodes every
value), so the simulator and the driver share one source of truth. Each request
first advances the plant to "now", then fills the requested registers (reads) or
applies the written values to the plant (writes). Addresses that are not in the map
answer with the Modbus exception ILLEGAL_ADDRESS.

Transports: Modbus TCP, Modbus RTU over a pty pair (the server opens one pty, the
client another, and a byte bridge joins their masters), and RTU framing over TCP for
pyserial ``socket://`` URLs. Fault injection (``plc.faults``) works on every transport:

* ``drop``: the request is processed but the response bytes are swallowed;
* ``delay_s``: every mapped request is held this long before it is answered;
* ``corrupt``: RTU responses get a wrong CRC, TCP responses become garbage bytes;
* ``await stop_server()`` / ``await start_server()``: stop listening (dropping clients)
  and serve again on the same port or pty.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import random
import time
import tty
from collections.abc import Callable
from dataclasses import dataclass

from pymodbus.constants import ExcCodes
from pymodbus.framer import FramerType
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from daq.config import Channel, RigConfig
from daq.registers import decode, encode
from daq.sim.plant import Plant
from daq.sim.plant_channels import read_channel, write_channel

_KIND_OF_FC = {1: "coil", 5: "coil", 15: "coil", 2: "discrete", 4: "input"}
_KIND_OF_FC.update({fc: "holding" for fc in (3, 6, 16, 22, 23)})
_WRITE_FCS = {5, 6, 15, 16, 22}
_BIT_KINDS = ("coil", "discrete")
TICK_S = 0.01


@dataclass
class Faults:
    """Fault injection switches; change them at any time from the simulator's loop."""

    drop: bool = False
    #: Swallow only this many next responses (one lost poll, without losing the device).
    drop_next: int = 0
    delay_s: float = 0.0
    corrupt: bool = False

    def clear(self) -> None:
        """Back to a healthy PLC."""
        self.drop, self.drop_next, self.delay_s, self.corrupt = False, 0, 0.0, False

    def take_drop(self) -> bool:
        """Whether to swallow the response being sent (``drop``, or one of ``drop_next``)."""
        if self.drop_next > 0:
            self.drop_next -= 1
            return True
        return self.drop


class SimulatedPLC:
    """A Modbus server in front of ``plant``; start one transport, stop and restart it."""

    def __init__(
        self, rig: RigConfig, plant: Plant, *, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.rig = rig
        self.plant = plant
        self.clock = clock
        self.unit_id = rig.modbus.unit_id
        self.faults = Faults()
        self._rng = random.Random(plant.scenario.seed + 1)
        self._jitter_s = plant.scenario.sensors.timestamp_jitter_s
        self._by_kind: dict[str, list[Channel]] = {k: [] for k in ("coil", "discrete")}
        self._by_kind.update({"holding": [], "input": []})
        for ch in rig.channels:
            self._by_kind[ch.kind].append(ch)
        self._covered = {
            kind: {a for ch in chans for a in range(ch.address, ch.address + ch.width)}
            for kind, chans in self._by_kind.items()
        }
        self._server: ModbusTcpServer | ModbusSerialServer | None = None
        self._make_server: Callable[[], ModbusTcpServer | ModbusSerialServer] | None = None
        self._rtu = False
        self._ticker: asyncio.Task | None = None
        self._bridge: _PtyBridge | None = None
        self.port: int | None = None

    # ---- device model --------------------------------------------------------------------
    def _device(self) -> SimDevice:
        blocks: list[list[SimData]] = []
        for kind in ("coil", "discrete", "holding", "input"):
            chans = self._by_kind[kind]
            if kind in _BIT_KINDS:
                data = [SimData(c.address, values=[False], datatype=DataType.BITS) for c in chans]
            else:
                data = [
                    SimData(c.address, count=c.width, datatype=DataType.REGISTERS) for c in chans
                ]
            if not data:  # an empty kind: one invalid register, so every read is an exception
                fill = DataType.BITS if kind in _BIT_KINDS else DataType.INVALID
                data = [SimData(0, values=[False] if kind in _BIT_KINDS else 0, datatype=fill)]
            blocks.append(data)
        coils, discretes, holdings, inputs = blocks
        return SimDevice(
            self.unit_id, simdata=(coils, discretes, holdings, inputs), action=self._action
        )

    async def _action(
        self,
        function_code: int,
        start_address: int,
        address: int,
        count: int,
        registers: list[int],
        set_values: list[int] | list[bool] | None,
    ) -> ExcCodes | None:
        kind = _KIND_OF_FC.get(function_code)
        if kind is None:
            return ExcCodes.ILLEGAL_FUNCTION
        if not self._covered[kind].issuperset(range(address, address + count)):
            return ExcCodes.ILLEGAL_ADDRESS
        if self.faults.delay_s > 0:
            await asyncio.sleep(self.faults.delay_s)
        self.plant.advance_to(self.clock())
        if set_values is not None:
            try:
                self._apply_writes(kind, address, list(set_values), start_address, registers)
            except ValueError:
                return ExcCodes.ILLEGAL_VALUE
        elif function_code not in _WRITE_FCS:
            self._fill(kind, address, count, start_address, registers)
            if self._jitter_s > 0:
                await asyncio.sleep(self._rng.uniform(0.0, self._jitter_s))
        return None

    @property
    def answers_at_once(self) -> bool:
        """``serve`` answers without waiting on the loop: no ``faults.delay_s`` and no
        timestamp jitter in the scenario."""
        return self.faults.delay_s <= 0 and self._jitter_s <= 0

    async def serve(
        self,
        function_code: int,
        start_address: int,
        address: int,
        count: int,
        registers: list[int],
        set_values: list[int] | list[bool] | None,
    ) -> ExcCodes | None:
        """Answer one request in process, as the server would (``daq.sim.inprocess``):
        reads fill ``registers`` (words from ``start_address``; bits packed 16 a word),
        writes reach the plant; an exception code for a request the PLC refuses."""
        return await self._action(
            function_code, start_address, address, count, registers, set_values
        )

    def _fill(self, kind: str, address: int, count: int, start: int, registers: list[int]) -> None:
        """Write the plant's present values into the datastore registers being read."""
        end = address + count
        for ch in self._by_kind[kind]:
            if ch.address + ch.width <= address or ch.address >= end:
                continue
            value = read_channel(self.plant, ch.name)
            if value is None:
                continue  # a channel the plant does not model keeps what was written
            if kind in _BIT_KINDS:
                word = ch.address // 16 - start
                bit = 1 << (ch.address % 16)
                registers[word] = registers[word] | bit if value else registers[word] & ~bit
            else:
                words = encode(ch, value)
                registers[ch.address - start : ch.address - start + ch.width] = words

    def _apply_writes(
        self, kind: str, address: int, values: list, start: int, registers: list[int]
    ) -> None:
        """Hand written values to the plant (coils per bit; registers per whole channel)."""
        end = address + len(values)
        for ch in self._by_kind[kind]:
            if ch.address + ch.width <= address or ch.address >= end:
                continue
            if kind in _BIT_KINDS:
                write_channel(self.plant, ch.name, 1.0 if values[ch.address - address] else 0.0)
                continue
            words = []
            for a in range(ch.address, ch.address + ch.width):
                words.append(values[a - address] if address <= a < end else registers[a - start])
            write_channel(self.plant, ch.name, decode(ch, words))

    # ---- fault hook on the byte stream ----------------------------------------------------
    def _trace_packet(self, sending: bool, data: bytes) -> bytes:
        if not sending:
            return data
        if self.faults.take_drop():
            return b""
        if self.faults.corrupt and data:
            if self._rtu:
                return data[:-1] + bytes([data[-1] ^ 0xFF])  # wrong CRC
            return bytes(self._rng.randrange(256) for _ in data)
        return data

    # ---- transports ----------------------------------------------------------------------
    async def start_tcp(self, host: str = "127.0.0.1", port: int = 0) -> int:
        """Serve Modbus TCP; returns the bound port (``port=0``: any free port)."""

        def make() -> ModbusTcpServer:
            return ModbusTcpServer(
                self._device(), address=(host, self.port or port), trace_packet=self._trace_packet
            )

        await self._start(make, rtu=False)
        return self.port or 0

    async def start_rtu_tcp(self, host: str = "127.0.0.1", port: int = 0) -> str:
        """Serve Modbus RTU framing over TCP; returns the pyserial URL ``socket://host:N``."""

        def make() -> ModbusTcpServer:
            return ModbusTcpServer(
                self._device(),
                framer=FramerType.RTU,
                address=(host, self.port or port),
                trace_packet=self._trace_packet,
            )

        await self._start(make, rtu=True)
        return f"socket://{host}:{self.port}"

    async def start_rtu_pty(self) -> str:
        """Serve Modbus RTU on a pty; returns the device path the client opens."""
        self._bridge = _PtyBridge()
        self._bridge.start()
        server_path = self._bridge.server_path
        mb = self.rig.modbus

        def make() -> ModbusSerialServer:
            return ModbusSerialServer(
                self._device(),
                port=server_path,
                baudrate=mb.baudrate,
                parity=mb.parity,
                stopbits=mb.stopbits,
                bytesize=mb.bytesize,
                timeout=0.1,
                trace_packet=self._trace_packet,
            )

        await self._start(make, rtu=True)
        return self._bridge.client_path

    async def _start(self, make: Callable, *, rtu: bool) -> None:
        if self._make_server is not None:
            raise RuntimeError("this simulated PLC is already serving; stop() it first")
        self._make_server, self._rtu = make, rtu
        await self.start_server()
        if self._ticker is None:
            self._ticker = asyncio.create_task(self._tick(), name="sim-plant-ticker")

    async def start_server(self) -> None:
        """(Re)start serving on the same endpoint as before."""
        if self._make_server is None:
            raise RuntimeError("no transport chosen: call start_tcp/start_rtu_* first")
        if self._server is not None:
            return
        server = self._make_server()
        await server.serve_forever(background=True)
        sockets = getattr(server.transport, "sockets", None)
        if sockets:
            self.port = sockets[0].getsockname()[1]
        self._server = server

    async def stop_server(self) -> None:
        """Stop serving (clients are disconnected); the plant keeps running."""
        if self._server is not None:
            server, self._server = self._server, None
            await server.shutdown()
            await asyncio.sleep(0)

    async def stop(self) -> None:
        """Stop serving, stop the plant ticker and release the pty pair."""
        await self.stop_server()
        if self._ticker is not None:
            self._ticker.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._ticker
            self._ticker = None
        if self._bridge is not None:
            self._bridge.close()
            self._bridge = None
        self._make_server = None
        self.port = None

    async def _tick(self) -> None:
        """Advance the plant at ~100 Hz so limits trip even when nobody polls."""
        while True:
            self.plant.advance_to(self.clock())
            await asyncio.sleep(TICK_S)


class _PtyBridge:
    """Two pty pairs joined master-to-master: a null-modem cable between two device paths."""

    def __init__(self) -> None:
        self._server_master, self._server_slave = os.openpty()
        self._client_master, self._client_slave = os.openpty()
        for fd in (self._server_slave, self._client_slave):
            tty.setraw(fd)  # no echo, no line discipline before pyserial opens it
        self.server_path = os.ttyname(self._server_slave)
        self.client_path = os.ttyname(self._client_slave)
        self._loop: asyncio.AbstractEventLoop | None = None

    def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        os.set_blocking(self._server_master, False)
        os.set_blocking(self._client_master, False)
        self._loop.add_reader(
            self._server_master, self._copy, self._server_master, self._client_master
        )
        self._loop.add_reader(
            self._client_master, self._copy, self._client_master, self._server_master
        )

    @staticmethod
    def _copy(src: int, dst: int) -> None:
        try:
            data = os.read(src, 4096)
        except OSError:
            return
        if data:
            with contextlib.suppress(OSError):
                os.write(dst, data)

    def close(self) -> None:
        if self._loop is not None:
            for fd in (self._server_master, self._client_master):
                self._loop.remove_reader(fd)
        for fd in (
            self._server_master,
            self._server_slave,
            self._client_master,
            self._client_slave,
        ):
            with contextlib.suppress(OSError):
                os.close(fd)
