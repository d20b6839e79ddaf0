"""A minimal register-map PLC for driver tests: a real pymodbus server on a real socket.

Serves every channel of a rig file from a dict the test controls (``set(name, SI)``),
records writes, and has fault knobs (``delay_s`` before each answer, ``fail_reads``
to answer with an exception). Unit tests use it where they need exact control of
the words on the wire; end-to-end tests use the product's simulated rig.
"""

from __future__ import annotations

import asyncio
import time

from pymodbus.constants import ExcCodes
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from daq import registers
from daq.config import RigConfig

_READ_FC = {1: "coil", 2: "discrete", 3: "holding", 4: "input"}


class MapServer:
    """Modbus server for ``rig``'s register map, TCP (``port``) or RTU (``serial_port``)."""

    def __init__(self, rig: RigConfig, *, port: int = 0, serial_port: str | None = None):
        self.rig = rig
        self.port = port
        self.serial_port = serial_port
        self.words: dict[str, dict[int, int]] = {k: {} for k in _READ_FC.values()}
        for ch in rig.channels:
            for i in range(ch.width):
                self.words[ch.kind][ch.address + i] = 0
        self.delay_s = 0.0
        self.fail_reads = False
        #: The next this-many writes answer ``slow_write_s`` late (after the client's timeout).
        self.slow_writes = 0
        self.slow_write_s = 0.2
        #: The same for reads; ``late_replies`` counts the late replies sent.
        self.slow_reads = 0
        self.slow_read_s = 0.2
        self.late_replies = 0
        #: Like a PLC scan: heartbeat +1 per 10 ms and plc_clock in ms, while True.
        self.heartbeat_running = True
        self.requests = 0
        self._server: ModbusTcpServer | ModbusSerialServer | None = None

    # ---- values ------------------------------------------------------------------
    def set(self, name: str, value: float) -> None:
        """Put an SI value (or raw for wrapping counters via ``set_raw``) on the wire."""
        ch = self.rig.channel(name)
        if ch.type == "bool":
            self.words[ch.kind][ch.address] = 1 if value else 0
            return
        for i, w in enumerate(registers.encode(ch, value)):
            self.words[ch.kind][ch.address + i] = w

    def set_raw(self, name: str, raw: int) -> None:
        """Put a raw (unscaled) value on the wire, wrapping counters wrap."""
        ch = self.rig.channel(name)
        for i, w in enumerate(registers.raw_to_words(ch, raw)):
            self.words[ch.kind][ch.address + i] = w

    def get(self, name: str) -> float:
        """The SI value the server holds for ``name``."""
        ch = self.rig.channel(name)
        if ch.type == "bool":
            return float(self.words[ch.kind][ch.address])
        w = [self.words[ch.kind][ch.address + i] for i in range(ch.width)]
        return registers.decode(ch, w)

    # ---- server ------------------------------------------------------------------
    def _device(self) -> SimDevice:
        def blocks(kind: str, bits: bool) -> list[SimData]:
            addrs = sorted(self.words[kind])
            if not addrs:
                addrs = [0]
            n = addrs[-1] - addrs[0] + 1
            if bits:
                return [SimData(addrs[0], count=n, values=False, datatype=DataType.BITS)]
            return [SimData(addrs[0], count=n, values=0, datatype=DataType.REGISTERS)]

        return SimDevice(
            id=self.rig.modbus.unit_id,
            simdata=(
                blocks("coil", True),
                blocks("discrete", True),
                blocks("holding", False),
                blocks("input", False),
            ),
            action=self._action,
        )

    async def _action(self, fc, start, address, count, regs, set_values):
        self.requests += 1
        if self.delay_s:
            await asyncio.sleep(self.delay_s)  # fault knob: a PLC slow to answer
        if fc in (5, 6, 15, 16) and set_values is not None and self.slow_writes:
            self.slow_writes -= 1
            await asyncio.sleep(self.slow_write_s)  # fault knob: a reply after the timeout
        if fc in _READ_FC and self.slow_reads:
            self.slow_reads -= 1
            await asyncio.sleep(self.slow_read_s)  # fault knob: a reply after the timeout
            self.late_replies += 1  # (its registers are filled below, in this same step)
        if fc in _READ_FC:
            if self.fail_reads:
                return ExcCodes.DEVICE_FAILURE
            if self.heartbeat_running:
                self.set_raw("heartbeat", int(time.monotonic() * 100))
                self.set_raw("plc_clock", int(time.monotonic() * 1000))
            kind = _READ_FC[fc]
            table = self.words[kind]
            if fc in (1, 2):  # packed bits: register r holds bits 16r .. 16r+15
                for r in range(len(regs) - 1):
                    base = (start + r) * 16
                    regs[r] = sum(1 << b for b in range(16) if table.get(base + b))
            else:
                for r in range(len(regs) - 1):
                    regs[r] = table.get(start + r, 0)
        elif set_values is None:
            pass  # the server reading back what it just wrote
        elif fc in (5, 15):
            for i, v in enumerate(set_values):
                self.words["coil"][address + i] = 1 if v else 0
        elif fc in (6, 16):
            for i, v in enumerate(set_values):
                self.words["holding"][address + i] = int(v)
        return None

    async def start(self) -> None:
        """Start serving (again, on the same port after ``stop``)."""
        if self.serial_port:
            self._server = ModbusSerialServer(
                self._device(), port=self.serial_port, baudrate=self.rig.modbus.baudrate
            )
        else:
            self._server = ModbusTcpServer(self._device(), address=("127.0.0.1", self.port))
        await self._server.serve_forever(background=True)  # returns once it listens
        if not self.serial_port:
            self.port = self._server.transport.sockets[0].getsockname()[1]

    async def stop(self) -> None:
        """Stop serving and drop every client connection."""
        if self._server is not None:
            await self._server.shutdown()
            self._server = None

    def rig_config(self, **modbus) -> RigConfig:
        """The rig file pointed at this server (plus any modbus overrides)."""
        if self.serial_port:
            conn = {"transport": "rtu", "serial_port": self.serial_port}
        else:
            conn = {"transport": "tcp", "host": "127.0.0.1", "port": self.port}
        conn.update(modbus)
        return self.rig.model_copy(update={"modbus": self.rig.modbus.model_copy(update=conn)})
