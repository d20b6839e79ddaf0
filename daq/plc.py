"""PLC/encoder client: the rig's Modbus device, read and written by channel name.

Everything comes from the rig file's register map (``RigConfig.channels``); no
address appears in code. Reads go out as one request per contiguous block
(``daq.blocks``), 32-bit values are decoded with the configured word order
(``daq.registers``), wrapping counters are unwrapped on the host (``daq.unwrap``)
and a channel older than its ``freshness_s`` is flagged STALE.

pymodbus' own retries and reconnects are switched off (``retries=0``,
``reconnect_delay=0``): a failed request fails at once, and this client runs its
own reconnect loop in the background with exponential back-off between
``modbus.reconnect_min_s`` and ``modbus.reconnect_max_s``, so a caller on a clock
never waits for a reconnect.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from pymodbus.client import AsyncModbusSerialClient, AsyncModbusTcpClient
from pymodbus.exceptions import ModbusException

from daq import registers
from daq.blocks import ReadBlock, plan_blocks
from daq.clock import REAL_CLOCK, Clock
from daq.config import Channel, RigConfig
from daq.sample import Quality
from daq.unwrap import CounterUnwrapper

#: How long a write keeps trying (its reply late or lost, the link reconnecting) before it
#: fails, s. A write sets a value, so repeating it is harmless. Longer than the hole any run
#: tolerates in its samples (``daq.vocabulary.AxisTerms.loss_tolerance_s``, at most 0.5 s):
#: a PLC stall a run rides through never fails its release, its stop or an operator's act.
WRITE_WITHIN_S = 1.0

_RAW_RANGE = {
    "uint16": (0, 0xFFFF),
    "int16": (-0x8000, 0x7FFF),
    "uint32": (0, 0xFFFFFFFF),
    "int32": (-0x80000000, 0x7FFFFFFF),
}


class DeviceError(RuntimeError):
    """A PLC request failed; the message names the channel/address and what failed.

    ``link_failure`` is True when the link failed (timeout, disconnect) rather than
    the PLC answering with an exception.
    """

    link_failure: bool = True


@dataclass(frozen=True, slots=True)
class Reading:
    """One channel's value in SI units.

    ``t_mono`` is the monotonic time (s) the value was last fresh: read
    successfully, or for a wrapping counter, last seen advancing. ``quality`` is
    ERROR when this poll could not read the channel (``value`` is then the last
    good value, NaN if none) and STALE when ``t_mono`` is older than the
    channel's ``freshness_s``.
    """

    value: float
    t_mono: float
    quality: Quality = Quality.OK


@dataclass
class PlcStats:
    """Counters of the client's life (requests, not polls)."""

    reads: int = 0
    errors: int = 0
    reconnects: int = 0
    last_error: str | None = None


class PlcClient:
    """Modbus TCP or RTU client for the rig's PLC/encoder (see module docstring)."""

    def __init__(
        self,
        rig: RigConfig,
        *,
        channels: Sequence[str] | None = None,
        clock: Clock = REAL_CLOCK,
        transport: Callable[[], Any] | None = None,
    ) -> None:
        """``channels`` limits what ``read_all`` polls (e.g. only the encoders, for a fast
        loop); default: every non-``sim_only`` channel of the register map. ``clock`` stamps
        readings; ``transport`` makes the pymodbus-shaped client instead of the rig file's
        TCP or RTU one (``daq.sim.inprocess``: the simulated PLC in process)."""
        self.rig = rig
        self.clock = clock
        self._transport = transport
        self.modbus = rig.modbus
        self.stats = PlcStats()
        polled = [c for c in rig.channels if not c.sim_only]
        if channels is not None:
            polled = [rig.channel(name) for name in channels]  # KeyError names the known ones
        self.blocks: list[ReadBlock] = plan_blocks(polled)
        self._unwrappers: dict[str, CounterUnwrapper] = {
            c.name: CounterUnwrapper(registers.wrap_period(c)) for c in rig.channels if c.wraps
        }
        self._last: dict[str, Reading] = {}
        # Made on first connect: pymodbus clients bind to the running event loop.
        self._client: Any = None
        self._reconnect_task: asyncio.Task | None = None
        self._closed = False

    @property
    def channel_names(self) -> tuple[str, ...]:
        """Names ``read_all`` returns: every non-``sim_only`` channel, in read order."""
        return tuple(c.name for b in self.blocks for c in b.channels)

    # ---- connection ----------------------------------------------------------------
    @property
    def endpoint(self) -> str:
        """Where the PLC is, for messages: ``tcp 127.0.0.1:5020 unit 1``."""
        m = self.modbus
        where = f"tcp {m.host}:{m.port}" if m.transport == "tcp" else f"rtu {m.serial_port}"
        return f"{where} unit {m.unit_id}"

    @property
    def _setting(self) -> str:
        """The rig-file settings that say where the PLC is."""
        if self.modbus.transport == "tcp":
            return "host, port, unit_id"
        return "serial_port, baudrate, unit_id"

    @property
    def connected(self) -> bool:
        """True while the transport to the PLC is open."""
        return self._client is not None and bool(self._client.connected)

    def _make_client(self) -> Any:
        if self._transport is not None:
            return self._transport()
        m = self.modbus
        if m.transport == "tcp":
            return AsyncModbusTcpClient(
                m.host, port=m.port, timeout=m.timeout_s, retries=0, reconnect_delay=0, name="plc"
            )
        # A device path or any pyserial URL (socket://host:port, rfc2217://...): pymodbus
        # opens it with serial.serial_for_url and speaks RTU framing over it.
        return AsyncModbusSerialClient(
            str(m.serial_port),
            baudrate=m.baudrate,
            parity=m.parity,
            stopbits=m.stopbits,
            bytesize=m.bytesize,
            timeout=m.timeout_s,
            retries=0,
            reconnect_delay=0,
            name="plc",
        )

    async def _attempt(self) -> bool:
        if self._client is None:
            self._client = self._make_client()
        try:
            return bool(await self._client.connect())
        except Exception as err:  # pyserial raises for a missing device path
            self.stats.last_error = f"connect to {self.endpoint} failed: {err}"
            return False

    async def connect(self, *, timeout_s: float | None = None) -> None:
        """Open the connection.

        Without ``timeout_s``: one attempt, DeviceError if it fails. With it: retry
        with exponential back-off (``reconnect_min_s`` doubling to ``reconnect_max_s``)
        until connected or ``timeout_s`` has passed, then DeviceError.
        """
        self._closed = False
        if self.connected:
            return
        deadline = self.clock.now() + (timeout_s or 0.0)
        delay = self.modbus.reconnect_min_s
        attempts = 0
        while True:
            attempts += 1
            if await self._attempt():
                return
            remaining = deadline - self.clock.now()
            if timeout_s is None or remaining <= 0:
                raise DeviceError(
                    f"cannot connect to PLC at {self.endpoint} after {attempts} attempt(s)"
                    + (f" in {timeout_s} s" if timeout_s is not None else "")
                    + f" (rig file [modbus] {self._setting})"
                )
            await asyncio.sleep(min(delay, remaining))
            delay = min(2 * delay, self.modbus.reconnect_max_s)

    async def close(self) -> None:
        """Stop reconnecting and close the connection."""
        self._closed = True
        task, self._reconnect_task = self._reconnect_task, None
        if task is not None:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        if self._client is not None:
            self._client.close()

    def _ensure_reconnecting(self) -> None:
        if self._closed or self.connected:
            return
        if self._reconnect_task is None or self._reconnect_task.done():
            self._reconnect_task = asyncio.get_running_loop().create_task(
                self._reconnect_loop(), name="plc reconnect"
            )

    async def _reconnect_loop(self) -> None:
        delay = self.modbus.reconnect_min_s
        while not self._closed and not self.connected:
            await asyncio.sleep(delay)
            if await self._attempt():
                self.stats.reconnects += 1
                return
            delay = min(2 * delay, self.modbus.reconnect_max_s)

    # ---- requests ------------------------------------------------------------------
    def _fail(
        self, what: str | ReadBlock, err: object, *, link: bool = True, counted: bool = False
    ) -> DeviceError:
        """Count a failed request (unless already ``counted``); ``link`` = the link failed
        (timeout, disconnect)."""
        self.stats.errors += 0 if counted else 1
        if isinstance(what, ReadBlock):
            what = f"read of {what.describe()}"
        if isinstance(err, BaseException):
            err = str(err) or type(err).__name__
        message = f"PLC {what} at {self.endpoint} failed: {err}"
        self.stats.last_error = message
        if not self.connected:
            self._ensure_reconnecting()
        error = DeviceError(message)
        error.link_failure = link
        return error

    async def _read_block(self, block: ReadBlock) -> list[int] | list[bool]:
        if not self.connected:
            raise self._fail(block, "not connected (reconnecting in the background)")
        c = self._client
        assert c is not None  # connected
        dev = self.modbus.unit_id
        call = {
            "input": c.read_input_registers,
            "holding": c.read_holding_registers,
            "coil": c.read_coils,
            "discrete": c.read_discrete_inputs,
        }[block.kind]
        try:
            rr = await call(block.start, count=block.count, device_id=dev)
        except (TimeoutError, ModbusException, OSError) as err:
            raise self._fail(block, err) from None
        if rr.isError():
            raise self._fail(block, f"exception response {rr}", link=False)
        values: list[int] | list[bool] = (
            list(rr.bits) if block.kind in ("coil", "discrete") else list(rr.registers)
        )
        if len(values) < block.count:
            raise self._fail(block, f"short response ({len(values)} of {block.count})", link=False)
        self.stats.reads += 1
        return values[: block.count]

    def _decode_block(
        self, block: ReadBlock, values: list[int] | list[bool], now: float
    ) -> dict[str, Reading]:
        out: dict[str, Reading] = {}
        for ch in block.channels:
            i = ch.address - block.start
            if ch.type == "bool":
                value = 1.0 if values[i] else 0.0
            else:
                raw = registers.words_to_raw(ch, list(values[i : i + ch.width]))
                if ch.wraps:
                    raw = self._unwrappers[ch.name].update(int(raw))
                value = float(registers.raw_to_si(ch, raw))
            t_fresh = now
            prev = self._last.get(ch.name)
            if ch.wraps and prev is not None and value == prev.value:
                t_fresh = prev.t_mono  # a counter that stopped counting is not fresh
            quality = Quality.STALE if now - t_fresh > ch.freshness_s else Quality.OK
            out[ch.name] = Reading(value, t_fresh, quality)
        return out

    async def read_all(self) -> dict[str, Reading]:
        """Poll every non-``sim_only`` channel, one request per contiguous block.

        A block whose read fails leaves its channels at the last good value with
        quality ERROR (plus STALE once older than ``freshness_s``); after a timeout
        or disconnect the remaining blocks of this poll are not attempted. Raises
        DeviceError when no block could be read.
        """
        readings: dict[str, Reading] = {}
        first_error: DeviceError | None = None
        give_up = False
        for block in self.blocks:
            values = None
            if not give_up:
                try:
                    values = await self._read_block(block)
                except DeviceError as err:
                    first_error = first_error or err
                    give_up = err.link_failure
            now = self.clock.now()
            if values is not None:
                fresh = self._decode_block(block, values, now)
                self._last.update(fresh)
                readings.update(fresh)
                continue
            for ch in block.channels:
                prev = self._last.get(ch.name)
                value, t_fresh = (prev.value, prev.t_mono) if prev else (math.nan, -math.inf)
                quality = Quality.ERROR
                if now - t_fresh > ch.freshness_s:
                    quality |= Quality.STALE
                readings[ch.name] = Reading(value, t_fresh, quality)
        if first_error is not None and all(r.quality & Quality.ERROR for r in readings.values()):
            raise first_error
        return readings

    async def read(self, name: str) -> float:
        """Read one channel (``sim_only`` ones too) in SI units; wrapping counters unwrapped."""
        ch = self.rig.channel(name)
        block = ReadBlock(ch.kind, ch.address, ch.width, (ch,))
        values = await self._read_block(block)
        reading = self._decode_block(block, values, self.clock.now())[name]
        self._last[name] = reading
        return reading.value

    async def write(
        self, name: str, value: float | bool, *, within_s: float = WRITE_WITHIN_S
    ) -> None:
        """Write a coil (bool) or holding register (SI value) by channel name. A write whose
        reply is late or lost, or that finds the link reconnecting, is tried again one
        ``timeout_s`` apart for ``within_s`` s (``WRITE_WITHIN_S``); then ``DeviceError``
        naming the tries."""
        ch = self.rig.channel(name)
        what = f"write of {name!r} ({ch.kind} address {ch.address})"
        if ch.kind in ("input", "discrete"):
            raise DeviceError(f"PLC {what}: {ch.kind} channels are read-only")
        if ch.kind == "coil":
            if not isinstance(value, bool | int) or value not in (0, 1):
                raise ValueError(f"channel {name!r}: coil value must be true/false, got {value!r}")
            words: list[int] | None = None
        else:
            words = registers.encode(ch, _check_range(ch, float(value)))
        # A busy PLC or host stalls the link for a few tenths of a second (and pymodbus drops
        # it after a few timeouts in a row): the write waits that out, as the run's samples do.
        give_up_at = self.clock.now() + within_s
        tries = 0
        while True:
            error = "not connected (reconnecting in the background)"
            sent = self.connected  # a request went out (and failed, below: counted)
            if sent:
                tries += 1
                dev = self.modbus.unit_id
                assert self._client is not None  # connected
                try:
                    if words is None:
                        rr = await self._client.write_coil(ch.address, bool(value), device_id=dev)
                    elif len(words) == 1:
                        rr = await self._client.write_register(ch.address, words[0], device_id=dev)
                    else:
                        rr = await self._client.write_registers(ch.address, words, device_id=dev)
                    break
                except (TimeoutError, ModbusException, OSError) as err:
                    self.stats.errors += 1
                    error = str(err) or type(err).__name__
            else:
                self._ensure_reconnecting()
            if self.clock.now() + self.modbus.timeout_s > give_up_at:
                tried = f"{error} ({tries} tries in {within_s:g} s)"
                raise self._fail(what, tried, counted=sent) from None
            # Let a late reply arrive while nothing waits for it (it would otherwise be
            # taken for the next try's reply and fail it on the transaction id).
            await self.clock.sleep(self.modbus.timeout_s)
        if rr.isError():
            raise self._fail(what, f"exception response {rr}", link=False)


def _check_range(ch: Channel, value: float) -> float:
    """Refuse a value the channel's register cannot hold (never clamp a setpoint)."""
    if not math.isfinite(value):
        raise ValueError(f"channel {ch.name!r}: value must be finite, got {value!r}")
    if ch.type == "float32":
        return value
    lo, hi = (raw * ch.scale + ch.offset for raw in _RAW_RANGE[ch.type])
    lo, hi = min(lo, hi), max(lo, hi)
    if not lo - abs(ch.scale) / 2 <= value <= hi + abs(ch.scale) / 2:
        raise ValueError(
            f"channel {ch.name!r}: value {value!r} {ch.unit} out of range; allowed {lo}..{hi}"
        )
    return value
