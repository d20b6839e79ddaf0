"""ThrusterDriver against the simulated controller over a real pty and over socket://.

Scheduled as the rig runs them, so a loaded test process only makes the test slower: the
controller answers from a CPU of its own (a real-time thread, ``ControllerThread``, or, when
the host is a child process, a real-time process, ``ControllerProcess``), and the driver's
line thread runs as a real-time session runs it (``SessionDriver``, thruster_child.py)."""

from __future__ import annotations

import asyncio
import itertools
import signal
import socket
import sys
import time
from asyncio.subprocess import Process
from collections.abc import AsyncIterator, Awaitable, Callable
from pathlib import Path
from types import SimpleNamespace

import pytest
from thruster_helpers import (
    ControllerProcess,
    ControllerThread,
    FakeClock,
    SessionDriver,
    limits,
    thruster_port,
)

from tests.support.waiting import until
from thrusters.driver import LINK_LOST_AFTER
from thrusters.emulator import ThrusterControllerEmulator

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)

CHILD = Path(__file__).with_name("thruster_child.py")


#: The child-process tests (signals, SIGKILL) on the serial line only: how a process ends
#: is the process's, and the frames it sends on the way are the ones this module's
#: in-process tests prove on both transports. (The atexit fallback writes raw bytes: both.)
ON_THE_SERIAL_LINE = pytest.mark.parametrize("device", ["pty"], indirect=True)


@pytest.fixture
async def controller() -> AsyncIterator[ControllerThread]:
    """The simulated controller on a CPU of its own; ``emulator.seen`` lists every change of
    its outputs as (monotonic time, fractions)."""
    seen: list[tuple[float, list[float]]] = []
    emu = ThrusterControllerEmulator(2, on_outputs=lambda f: seen.append((time.monotonic(), f)))
    emu.seen = seen  # type: ignore[attr-defined]
    thread = ControllerThread(emu)
    yield thread
    await thread.close()


@pytest.fixture(params=["pty", "socket"])
async def served(request, controller) -> tuple[ThrusterControllerEmulator, str]:
    return controller.emulator, await controller.serve(request.param)


@pytest.fixture(params=["pty", "socket"])
async def device(request) -> AsyncIterator[tuple[ControllerProcess, str]]:
    """The controller in a process of its own, for a host that is a child process."""
    process = ControllerProcess()
    try:
        yield process, await process.start(request.param)
    finally:
        await process.stop()


async def test_clamp_and_slew_visible_in_controller_outputs(served) -> None:
    emu, url = served
    clock = FakeClock()  # the slew limiter's time: commands 0.02 s apart, on any machine
    async with SessionDriver(thruster_port(url), limits(), clock=clock) as drv:
        await drv.arm()
        t0 = clock.t
        for _ in range(100):
            clock.t += 0.02
            assert await drv.command([1.0, -3.0])
            if emu.outputs == [0.8, -0.8]:
                break
        ramp_s = clock.t - t0
    outputs = [f for _, f in emu.seen]
    assert [0.8, -0.8] in outputs, "clamped to the rig's max_thruster_command, never beyond"
    assert max(abs(x) for f in outputs for x in f) <= 0.8
    # slew 2.0 /s: 0 → 0.8 takes 0.4 s; no step exceeds 2.0 /s × 0.02 s.
    assert ramp_s == pytest.approx(0.4)
    ramp = outputs[: outputs.index([0.8, -0.8]) + 1]  # zeroing at close is immediate
    steps = [abs(b[0] - a[0]) for a, b in itertools.pairwise(ramp)]
    assert max(steps) <= 0.04 + 1e-9
    assert outputs[-1] == [0.0, 0.0] and emu.state == "DISARMED"


async def test_zero_on_exception_exit(served) -> None:
    emu, url = served
    clock = FakeClock()
    with pytest.raises(RuntimeError, match="procedure failed"):
        async with SessionDriver(thruster_port(url), limits(), clock=clock) as drv:
            await drv.arm()
            clock.t += 0.1
            await drv.command([0.3, 0.3])
            clock.t += 0.1  # slew 2.0 /s: 0 → 0.3 in two steps
            await drv.heartbeat()
            assert emu.outputs == [0.3, 0.3]
            raise RuntimeError("procedure failed")
    assert emu.outputs == [0.0, 0.0] and emu.state == "DISARMED"
    assert emu.stats.accepted_commands[-1][1] == (0, 0)


async def test_garbage_and_corrupt_replies_are_counted_never_fatal(served, controller) -> None:
    emu, url = served
    async with SessionDriver(thruster_port(url), limits()) as drv:
        await drv.arm()
        await controller.call(emu.inject, b"\x00\x17 line noise \xff\r\n")
        assert await drv.command([0.1, 0.1])
        emu.corrupt_replies = 1
        assert not await drv.command([0.1, 0.1]), "a corrupted ACK is not an ACK"
        await controller.call(emu.inject, b"$ACK,9999,ARMED*0000\r\n\r\n")
        await controller.call(emu.inject, b"partial frame without end " * 20)
        assert await drv.heartbeat()
        assert drv.stats.garbage_lines >= 2
        assert drv.stats.corrupt_lines == 2
        assert drv.stats.timeouts == 1
    assert emu.outputs == [0.0, 0.0]


async def test_silent_controller_times_out_then_its_watchdog_latches(served) -> None:
    emu, url = served
    clock = FakeClock()
    drv = SessionDriver(thruster_port(url, ack_timeout_s=0.05), limits(), clock=clock)
    await drv.open()
    await drv.arm()
    clock.t += 0.1  # slew 2.0 /s: 0.2 in one step
    await drv.command([0.2, 0.2])
    assert emu.outputs == [0.2, 0.2]
    emu.silent = True
    t0 = time.monotonic()
    while emu.state == "ARMED" and time.monotonic() - t0 < 2:
        assert not await drv.heartbeat()
    assert emu.state == "WDT" and emu.outputs == [0.0, 0.0]
    # latched at its watchdog (emu.watchdog_s after the last frame it took), not before
    # it; the upper bound leaves a loaded test process's late loop room (the loop above
    # gives up at 2 s)
    assert emu.watchdog_s - 0.05 <= time.monotonic() - t0 <= 3 * emu.watchdog_s
    assert drv.stats.timeouts >= 3
    emu.silent = False
    # the controller answers again: with its latched watchdog, "disarmed", never an accept
    # (a loaded test process may answer the first heartbeat after ack_timeout_s: wait for the
    # answer, not for one heartbeat)
    t0 = time.monotonic()
    while not drv.stats.naks["disarmed"] and time.monotonic() - t0 < 2:
        assert not await drv.heartbeat()
    assert drv.stats.naks["disarmed"] == 1 and drv.state == "WDT"
    await drv.arm()
    assert await drv.command([0.05, 0.05])
    await drv.close()
    assert emu.state == "DISARMED"


async def test_heartbeat_keeps_controller_armed(served) -> None:
    emu, url = served
    async with SessionDriver(thruster_port(url), limits()) as drv:
        await drv.arm()
        await drv.command([0.1, 0.1])
        for _ in range(8):
            await asyncio.sleep(0.1)  # paced like the 10 Hz host, for 0.8 s > the watchdog
            assert await drv.heartbeat()
        assert emu.state == "ARMED" and emu.stats.watchdog_trips == 0
        status = await drv.query()
        assert status.state == "ARMED" and status.rpm == (0.0, 0.0)


@pytest.fixture
async def start_child() -> AsyncIterator[Callable[[str, str], Awaitable[Process]]]:
    """``await start_child(url, mode)``: thruster_child.py armed at 50 % thrust; a child still
    running when the test ends (it failed first) is killed, not left heartbeating on the line."""
    started: list[Process] = []

    async def start(url: str, mode: str) -> Process:
        proc = await asyncio.create_subprocess_exec(
            sys.executable, str(CHILD), url, mode, stdout=asyncio.subprocess.PIPE
        )
        started.append(proc)
        assert proc.stdout is not None
        assert await asyncio.wait_for(proc.stdout.readline(), 10) == b"armed\n"
        return proc

    yield start
    for proc in started:
        if proc.returncode is None:
            proc.kill()
            await proc.wait()


async def _wait_for_thrust(controller: ControllerProcess) -> None:
    """Until the controller has applied the child's 50 %: read from its record of outputs,
    not its present ones (the ``atexit`` child holds 50 % for only two heartbeats, which a
    loaded test process may sleep through)."""

    async def reached() -> bool:
        return [0.5, 0.5] in [f for _, f in (await controller.read()).seen]

    await until(reached, "the child at 50 % thrust", timeout_s=3)


async def _watchdog_tripped(emu: ThrusterControllerEmulator) -> None:
    """Until the controller's watchdog trips (the host sends nothing meanwhile)."""
    await until(lambda: emu.state == "WDT", "the controller's watchdog tripping", timeout_s=2)


@ON_THE_SERIAL_LINE
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
async def test_signal_zeroes_and_acks_before_the_process_exits(device, start_child, sig) -> None:
    controller, url = device
    proc = await start_child(url, "signals")
    await _wait_for_thrust(controller)
    acks_before = (await controller.read()).acks
    proc.send_signal(sig)
    assert await asyncio.wait_for(proc.wait(), 5) == -sig
    exited = time.monotonic()
    emu = await controller.read()
    zero_times = [t for t, cmds in emu.accepted_commands if cmds == (0, 0)]
    assert zero_times and zero_times[-1] < exited, "zero accepted (and ACKed) before exit"
    assert emu.acks >= acks_before + 2  # the zero and the DISARM were answered
    assert emu.outputs == [0.0, 0.0] and emu.state == "DISARMED"
    assert emu.watchdog_trips == 0, "zeroed by the driver, not by the watchdog"


@ON_THE_SERIAL_LINE
async def test_sigkill_leaves_it_to_the_controller_watchdog(device, start_child) -> None:
    controller, url = device
    proc = await start_child(url, "signals")
    await _wait_for_thrust(controller)
    proc.kill()
    await asyncio.wait_for(proc.wait(), 5)
    killed = time.monotonic()

    async def tripped() -> bool:
        return (await controller.read()).state != "ARMED"

    await until(tripped, "the watchdog tripping", timeout_s=2)
    emu = await controller.read()
    assert emu.state == "WDT" and emu.outputs == [0.0, 0.0]
    assert emu.watchdog_trips == 1
    assert emu.seen[-1][0] - killed <= 0.5


async def test_atexit_fallback_writes_zero_when_never_closed(device, start_child) -> None:
    controller, url = device
    proc = await start_child(url, "atexit")
    await _wait_for_thrust(controller)
    assert await asyncio.wait_for(proc.wait(), 5) == 3

    async def disarmed() -> bool:
        return (await controller.read()).state == "DISARMED"

    await until(disarmed, "the controller disarmed", timeout_s=5)
    emu = await controller.read()
    assert emu.accepted_commands[-1][1] == (0, 0)
    assert emu.outputs == [0.0, 0.0] and emu.state == "DISARMED"
    assert emu.watchdog_trips == 0


async def test_driver_reconnects_when_the_controller_comes_back() -> None:
    first = ControllerThread(ThrusterControllerEmulator(2))
    url = await first.serve("socket")
    port = int(url.rsplit(":", 1)[1])
    clock = FakeClock()
    drv = SessionDriver(thruster_port(url), limits(), clock=clock)
    await drv.open()
    await drv.arm()
    await first.close()  # controller (or its serial server) goes away
    assert not await drv.heartbeat()
    assert not await drv.heartbeat(), "still down: reconnect attempt fails, no exception"
    assert drv.link_lost  # LINK_LOST_AFTER = 2 frames failed: a zero frame was tried at once
    assert drv.stats.io_errors == 3
    second = ControllerThread(ThrusterControllerEmulator(2))
    emu2 = second.emulator
    await second.serve("socket", port=port)
    try:
        assert not await drv.heartbeat()  # reconnected; a fresh controller is DISARMED
        assert drv.stats.reconnects == 1 and drv.stats.naks["disarmed"] == 1
        await drv.arm()
        clock.t += 0.1  # slew 2.0 /s: 0.1 in one step
        assert await drv.command([0.1, 0.1]) and emu2.outputs == [0.1, 0.1]
        await drv.close()
        assert emu2.outputs == [0.0, 0.0] and emu2.state == "DISARMED"
    finally:
        await second.close()


async def test_recorded_outputs_bracket_every_change_the_controller_made(served) -> None:
    """Late and early heartbeats change the ramp; the record follows what was applied."""
    emu, url = served
    async with SessionDriver(thruster_port(url), limits()) as drv:
        await drv.arm()
        with drv.recording_outputs() as steps:
            for pause in (0.0, 0.02, 0.15, 0.05, 0.01, 0.12, 0.1, 0.1):
                await asyncio.sleep(pause)  # deliberately early and late heartbeats, real time
                await drv.command([0.5, -0.3])
            # No heartbeat for longer than the controller's watchdog: it zeroes the outputs.
            await _watchdog_tripped(emu)
            assert not await drv.command([0.5, -0.3])
        assert drv.state == "WDT"
    seen = [(0.0, [0.0, 0.0]), *emu.seen]
    applied = [(t, f) for (_, g), (t, f) in itertools.pairwise(seen) if f != g]
    assert [list(s.fractions) for s in steps] == [f for _, f in applied]
    assert steps[-2].fractions == (0.5, -0.3) and steps[-1].fractions == (0.0, 0.0)
    for step, (t_applied, _) in zip(steps, applied, strict=True):
        assert step.t_sent <= t_applied <= step.t_acked
    # The watchdog trip is bracketed by the last ACK before it and the refusal after it.
    assert steps[-1].t_acked - steps[-1].t_sent >= emu.watchdog_s


async def test_link_lost_after_consecutive_bad_replies_holds_zero_until_rearmed(served) -> None:
    """One spoiled reply is ridden out; LINK_LOST_AFTER in a row are a lost link: a zero
    frame goes out at once, commands stay zero, and only a new ARM clears the fault."""
    emu, url = served
    clock = FakeClock()
    async with SessionDriver(thruster_port(url), limits(), clock=clock) as drv:
        await drv.arm()
        clock.t += 0.1
        await drv.command([0.3, 0.3])
        assert emu.outputs[0] > 0
        emu.corrupt_replies = LINK_LOST_AFTER - 1
        for _ in range(LINK_LOST_AFTER):
            clock.t += 0.02  # still ramping: what is sent differs from what was confirmed
            await drv.command([0.3, 0.3])
        assert drv.fault is None and drv.missed_replies == 0
        emu.corrupt_replies = LINK_LOST_AFTER
        confirmed = emu.outputs
        t0 = time.monotonic()
        for _ in range(LINK_LOST_AFTER):
            clock.t += 0.02
            assert not await drv.command([0.3, 0.3])
        fault = await asyncio.wait_for(drv.wait_fault(), 1)
        assert fault.kind == "link_lost" and fault.t_confirmed < t0
        assert fault.reason.startswith(
            f"thruster link lost: {LINK_LOST_AFTER} consecutive replies missing (bad CRC)"
        )
        assert list(fault.outputs) == pytest.approx(confirmed)
        assert emu.outputs == [0.0, 0.0]  # the zero frame sent on detection got through
        assert await drv.command([0.3, 0.3]) and emu.outputs == [0.0, 0.0]  # held at zero
        await drv.arm()
        assert drv.fault is None
        clock.t += 0.1
        await drv.command([0.3, 0.3])
        assert emu.outputs[0] > 0


async def test_watchdog_trip_seen_in_the_reply_is_a_fault(served) -> None:
    emu, url = served
    async with SessionDriver(thruster_port(url), limits()) as drv:
        await drv.arm()
        await drv.command([0.2, 0.2])
        # no heartbeat: the controller trips
        await _watchdog_tripped(emu)
        assert not await drv.command([0.2, 0.2])  # NAK disarmed
        fault = await asyncio.wait_for(drv.wait_fault(), 1)
        assert fault.kind == "watchdog" and "watchdog tripped" in fault.reason
        assert drv.state == "WDT" and emu.outputs == [0.0, 0.0]


def test_closing_a_socket_line_hangs_up_without_pyserial_s_sleep(monkeypatch) -> None:
    """pyserial's ``socket://`` port sleeps 0.3 s in ``close`` ("quick reconnects"): every
    close of the simulated rig's thruster line paid it. The link's own port hangs up (the
    controller's end reads EOF) and sleeps nowhere."""
    from serial.urlhandler import protocol_socket

    from thrusters.link import open_serial_port

    slept: list[float] = []
    monkeypatch.setattr(protocol_socket, "time", SimpleNamespace(sleep=slept.append))
    with socket.create_server(("127.0.0.1", 0)) as server:
        host, port_number = server.getsockname()
        port = open_serial_port(f"socket://{host}:{port_number}", 115200)
        peer, _ = server.accept()
        with peer:
            peer.settimeout(30)  # a port that never hangs up fails here, not at the test's timeout
            port.write(b"$X\n")
            port.close()
            assert not port.is_open
            received = b""
            while chunk := peer.recv(64):  # ends at the hang-up
                received += chunk
    assert received == b"$X\n"
    assert slept == []
    port.close()  # closing twice is harmless, as pyserial's
