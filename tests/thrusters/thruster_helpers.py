"""Helpers for the thruster tests: a scripted controller in memory (``ExpectedProtocol``)
or on a real pty (``ScriptedPeer``), the simulated controller on a CPU of its own
(``ControllerThread``), rig settings."""

from __future__ import annotations

import asyncio
import json
import os
import select
import sys
import threading
import time
import tty
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from daq.config import Limits, load_rig
from daq.priority import thruster_link_realtime
from daq.sim.device_loop import DeviceLoop
from thrusters.driver import ThrusterDriver
from thrusters.emulator import ThrusterControllerEmulator
from thrusters.link import READ_SLICE_S, SerialLink
from thrusters.settings import ThrusterPort

RIG = load_rig()


class SessionDriver(ThrusterDriver):
    """A ``ThrusterDriver`` whose line I/O thread runs as a real-time session runs it
    (``daq/session.py``: at ``THRUSTER_LINK_PRIORITY`` where the OS allows).

    Beside a real-time controller thread in the same process: at normal priority that
    thread, polling the line every 10 ms, was taken off the CPU by a loaded machine while
    it held the GIL, and the controller's reply waited for it past the 0.05-0.1 s reply
    timeout (the inversion ``daq.priority`` describes for a session's workers)."""

    async def open(self, *, io_thread_setup: Callable[[], object] | None = None) -> None:
        await super().open(io_thread_setup=io_thread_setup or thruster_link_realtime)


def thruster_port(port: str, **overrides: object) -> ThrusterPort:
    """The BENBAM rig's [thrusters] section pointed at ``port``."""
    return RIG.thrusters.model_copy(update={"port": port, **overrides})


def limits(**overrides: object) -> Limits:
    """The BENBAM rig's [limits] (max command 0.8, slew 2.0 /s) with overrides."""
    return RIG.limits.model_copy(update=overrides)


Conversation = list[tuple[bytes, bytes | None]]


class ExpectedProtocol:
    """A fake controller in memory behind the driver's serial link, like PyMeasure's
    ``expected_protocol``: it expects exact bytes and answers with given bytes,
    ``[(expected_write, reply_or_None), ...]`` (None = stay silent).

    It is the link's port and its clock: a read with nothing to give advances the clock by
    one read slice, so a silent step costs the link its whole reply timeout without any
    real waiting, and the conversation is the same under any load."""

    url = "memory://thrusters"

    def __init__(self, conversation: Conversation) -> None:
        self.conversation = conversation
        self.t = 0.0
        self.step = 0
        self.error: str | None = None
        self.opened = 0
        self._written = b""
        self._rx = b""

    # The driver side.
    def driver(self, lim: Limits | None = None, *, clock: Callable[[], float] | None = None):
        cfg = thruster_port(self.url)
        link = SerialLink(
            self.url, cfg.baudrate, cfg.ack_timeout_s, open_port=self._open, clock=self.clock
        )
        extra = {} if clock is None else {"clock": clock}
        return ThrusterDriver(cfg, lim or limits(), link=link, **extra)

    def clock(self) -> float:
        return self.t

    def _open(self, url: str, baudrate: int) -> ExpectedProtocol:
        self.opened += 1
        return self

    # The pyserial port the link uses.
    @property
    def in_waiting(self) -> int:
        return len(self._rx)

    def reset_input_buffer(self) -> None:
        self._rx = b""

    def read(self, size: int = 1) -> bytes:
        if not self._rx:
            self.t += READ_SLICE_S  # a read that timed out
            return b""
        chunk, self._rx = self._rx[:size], self._rx[size:]
        return chunk

    def write(self, data: bytes) -> int:
        self._written += data
        while self._written and self.error is None:
            if self.step >= len(self.conversation):
                self.error = f"host wrote unexpected bytes {self._written!r}"
            else:
                expected, reply = self.conversation[self.step]
                if expected.startswith(self._written) and self._written != expected:
                    break  # a frame written in parts: wait for the rest
                if not self._written.startswith(expected):
                    self.error = f"step {self.step}: expected {expected!r}, got {self._written!r}"
                else:
                    self._written = self._written[len(expected) :]
                    self.step += 1
                    self._rx += reply or b""
        if self.error is not None:
            raise AssertionError(self.error)
        return len(data)

    def flush(self) -> None:
        pass

    def close(self) -> None:
        pass

    def assert_done(self) -> None:
        """Every step happened byte-exact and the host wrote nothing more."""
        assert self.error is None, self.error
        assert self.step == len(self.conversation), (
            f"stopped at step {self.step} of {len(self.conversation)}: "
            f"expected {self.conversation[self.step][0]!r} next"
        )
        assert self._written == b"", f"host wrote unexpected bytes {self._written!r}"


#: How long a driver talking to a `ScriptedPeer` waits for a reply (s), instead of the rig
#: file's 0.1 s: the peer answers from a thread of the test's process, which a loaded machine
#: can hold off longer than that (a full run here saw a scripted reply come after 0.1 s and
#: the driver retry past the script's end). The conversations check bytes and retries, not
#: the controller's speed; a silent step costs this long.
PTY_REPLY_S = 0.5


class ScriptedPeer:
    """A fake controller on a real pty that expects exact bytes and replies with given
    bytes: ``[(expected_write, reply_or_None), ...]`` (None = stay silent)."""

    def __init__(self, conversation: list[tuple[bytes, bytes | None]]) -> None:
        self.conversation = conversation
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.path = os.ttyname(self._slave)
        self.received: list[bytes] = []
        self.error: str | None = None
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _read_exact(self, n: int, timeout_s: float) -> bytes:
        data = b""
        deadline = time.monotonic() + timeout_s
        while len(data) < n:
            ready, _, _ = select.select([self.master], [], [], max(0, deadline - time.monotonic()))
            if not ready:
                break
            data += os.read(self.master, n - len(data))
        return data

    def _serve(self) -> None:
        for i, (expected, reply) in enumerate(self.conversation):
            got = self._read_exact(len(expected), 3.0)
            self.received.append(got)
            if got != expected:
                self.error = f"step {i}: expected {expected!r}, got {got!r}"
                return
            if reply:
                os.write(self.master, reply)

    def driver(self, lim: Limits | None = None, *, clock: Callable[[], float] | None = None):
        """A driver on this pty that waits `PTY_REPLY_S` for each reply."""
        extra = {} if clock is None else {"clock": clock}
        port = thruster_port(self.path, ack_timeout_s=PTY_REPLY_S)
        return ThrusterDriver(port, lim or limits(), **extra)

    def assert_done(self) -> None:
        """Every step happened byte-exact and the host wrote nothing more."""
        self._thread.join(5)
        assert self.error is None, self.error
        assert len(self.received) == len(self.conversation)
        extra = self._read_exact(1, 0.05)
        assert extra == b"", f"host wrote unexpected bytes {extra!r}"
        os.close(self.master)
        os.close(self._slave)


class FakeClock:
    """A monotonic clock the test advances by hand."""

    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


class ControllerThread:
    """``emulator`` served from a device loop of its own (``daq.sim.device_loop``: a thread
    that runs real-time just below the rig's clock where the OS allows), as the simulated rig
    runs: the real board answers and keeps its watchdog on a CPU of its own, whatever the
    host does.

    In the test's own loop at normal priority, a loaded worker read the host's frames late:
    the emulator then took a heartbeat sent in time for one past its watchdog (it tripped)
    and answered after the driver's reply timeout. Whatever it is told to do while it serves
    goes through ``call`` (its loop is not the test's); its state is read directly."""

    def __init__(self, emulator: ThrusterControllerEmulator) -> None:
        self.emulator = emulator
        self._device = DeviceLoop("thruster-controller")

    async def call(self, fn: Callable[..., Any], *args: Any) -> Any:
        """``fn(*args)`` on the controller's loop (awaited there if awaitable); its result."""
        return await asyncio.wrap_future(self._device.submit(fn, *args))

    async def serve(self, transport: str, **tcp: Any) -> str:
        """Serve on a new pty (``"pty"``: its path) or TCP (``"socket"``: its URL)."""
        if transport == "pty":
            return await self.call(self.emulator.start_pty)
        return await self.call(lambda: self.emulator.start_tcp(**tcp))

    async def close(self) -> None:
        """Stop serving and end the thread."""
        if not self._device.running:
            return
        try:
            await self.call(self.emulator.stop)
        finally:
            self._device.close()  # its loop has nothing left to run: at once


@dataclass(frozen=True)
class ControllerState:
    """What the controller process says of itself (``controller_process.py``)."""

    state: str
    outputs: list[float]
    acks: int
    watchdog_trips: int
    #: Accepted THR frames as (monotonic time, commands in per mille).
    accepted_commands: list[tuple[float, tuple[int, ...]]]
    #: Every change of its outputs as (monotonic time, fractions).
    seen: list[tuple[float, list[float]]]


class ControllerProcess:
    """The simulated controller of 2 thrusters in a real-time process of its own
    (``controller_process.py``): for tests whose host is another process, that only read
    what the controller did."""

    SCRIPT = Path(__file__).with_name("controller_process.py")

    def __init__(self) -> None:
        self._process: asyncio.subprocess.Process | None = None
        self.url = ""

    async def start(self, transport: str) -> str:
        """Serve on a new pty (``"pty"``) or TCP (``"socket"``); its path or URL."""
        self._process = await asyncio.create_subprocess_exec(
            sys.executable, str(self.SCRIPT), transport,
            stdin=asyncio.subprocess.PIPE, stdout=asyncio.subprocess.PIPE,
        )  # fmt: skip
        self.url = (await self._line()).strip()
        return self.url

    async def read(self) -> ControllerState:
        """The controller's state now."""
        assert self._process is not None and self._process.stdin is not None
        self._process.stdin.write(b"state\n")
        got = json.loads(await self._line())
        got["accepted_commands"] = [(t, tuple(c)) for t, c in got["accepted_commands"]]
        got["seen"] = [(t, f) for t, f in got["seen"]]
        return ControllerState(**got)

    async def _line(self) -> bytes:
        assert self._process is not None and self._process.stdout is not None
        line = await asyncio.wait_for(self._process.stdout.readline(), 10)
        assert line, f"the controller process ended (exit {await self._process.wait()})"
        return line

    async def stop(self) -> None:
        process, self._process = self._process, None
        if process is None:
            return
        assert process.stdin is not None
        process.stdin.close()
        try:
            await asyncio.wait_for(process.wait(), 5)
        finally:
            if process.returncode is None:
                process.kill()
                await process.wait()
