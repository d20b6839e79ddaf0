"""The simulated thruster controller, talked to with raw bytes over TCP and a pty.

It serves from a thread of its own (``ControllerThread``), as the real board answers from a
CPU of its own: the test is the host, and a loaded test process only makes the host late."""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator

import pytest
import serial
from thruster_helpers import ControllerThread

from tests.support.waiting import ANSWER_S, until
from thrusters import protocol as p
from thrusters.emulator import ThrusterControllerEmulator


class Line:
    """A raw TCP connection to the emulator: send bytes, read one reply line."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader, self.writer = reader, writer

    async def ask(self, raw: bytes) -> bytes:
        self.writer.write(raw)
        return await asyncio.wait_for(self.reader.readline(), 1.0)


@pytest.fixture
async def controller() -> AsyncIterator[ControllerThread]:
    """The controller on a thread of its own; ``emulator.seen`` lists every change of its
    outputs as (monotonic time, fractions)."""
    seen: list[tuple[float, list[float]]] = []
    emulator = ThrusterControllerEmulator(
        2,
        on_outputs=lambda f: seen.append((time.monotonic(), f)),
        telemetry=lambda: [(1500.0, 2.5), (-1200.0, 1.75)],
    )
    emulator.seen = seen  # type: ignore[attr-defined]
    thread = ControllerThread(emulator)
    yield thread
    await thread.close()


@pytest.fixture
def emu(controller: ControllerThread) -> ThrusterControllerEmulator:
    return controller.emulator


def outputs_seen(emu: ThrusterControllerEmulator) -> list[list[float]]:
    return [f for _, f in emu.seen]  # type: ignore[attr-defined]


@pytest.fixture
async def line(controller: ControllerThread) -> AsyncIterator[Line]:
    url = await controller.serve("socket")
    host, port = url.removeprefix("socket://").split(":")
    reader, writer = await asyncio.open_connection(host, int(port))
    yield Line(reader, writer)
    writer.close()


async def test_arm_then_thr_is_acked_and_sets_outputs(emu, line) -> None:
    assert await line.ask(p.arm_frame(1)) == p.ack_frame(1, "ARMED")
    assert (
        await line.ask(p.thr_frame(2, [250, -500]))
        == b"$ACK,2,ARMED*" + (p.ack_frame(2, "ARMED")[13:])
    )
    assert emu.outputs == [0.25, -0.5]
    assert outputs_seen(emu) == [[0.25, -0.5]]
    assert emu.stats.acks == 2 and emu.stats.frames_ok == 2


async def test_nak_reasons(emu, line) -> None:
    assert await line.ask(p.thr_frame(1, [0, 0])) == p.nak_frame(1, "disarmed")
    await line.ask(p.arm_frame(2))
    bad_crc = p.thr_frame(3, [10, 10])[:-6] + b"0000\r\n"
    assert await line.ask(bad_crc) == p.nak_frame(3, "crc")
    assert await line.ask(b"$THR,4,10,10*00\r\n") == p.nak_frame(4, "malformed")
    assert await line.ask(p.encode_frame("THR,5,1001,0")) == p.nak_frame(5, "range")
    assert await line.ask(p.encode_frame("THR,6,10")) == p.nak_frame(6, "malformed")
    assert await line.ask(p.encode_frame("THR,7,10,0,0")) == p.nak_frame(7, "malformed")
    assert await line.ask(p.encode_frame("THR,8,1.5,0")) == p.nak_frame(8, "malformed")
    assert await line.ask(p.thr_frame(10, [100, 100])) == p.ack_frame(10, "ARMED")
    assert await line.ask(p.thr_frame(10, [300, 300])) == p.nak_frame(10, "stale")
    assert await line.ask(p.thr_frame(9, [300, 300])) == p.nak_frame(9, "stale")
    assert emu.outputs == [0.1, 0.1], "a rejected frame never changes the outputs"
    assert dict(emu.stats.naks) == {"disarmed": 1, "crc": 1, "malformed": 4, "range": 1, "stale": 2}
    assert emu.stats.crc_errors == 1


async def test_seq_wraps_and_rearm_resets_window(line) -> None:
    await line.ask(p.arm_frame(0))
    assert await line.ask(p.thr_frame(65535, [1, 1])) == p.ack_frame(65535, "ARMED")
    assert await line.ask(p.thr_frame(0, [2, 2])) == p.ack_frame(0, "ARMED")
    assert await line.ask(p.arm_frame(1)) == p.ack_frame(1, "ARMED")
    assert await line.ask(p.thr_frame(0, [3, 3])) == p.ack_frame(0, "ARMED")


async def test_garbage_lines_are_counted_not_answered(emu, line) -> None:
    line.writer.write(b"\x00\x01hello\r\n" + b"x" * 300)
    line.writer.write(b"\n")  # ends the over-long line; nothing answers
    assert await line.ask(p.qry_frame(1)) == p.sta_frame(
        1, "DISARMED", [(1500.0, 2.5), (-1200.0, 1.75)]
    )
    assert emu.stats.garbage_lines == 2


async def test_watchdog_trips_latches_and_rearms(emu, line) -> None:
    await line.ask(p.arm_frame(1))
    await line.ask(p.thr_frame(2, [400, 400]))
    # QRY does not feed the watchdog: only accepted ARM/THR frames do.
    await line.ask(p.qry_frame(3))
    await until(lambda: emu.state != "ARMED", "the watchdog tripping", timeout_s=2)
    assert emu.state == "WDT"
    # From the last frame it took to the zeroing, on the controller's own clock.
    tripped_after = emu.seen[-1][0] - emu.stats.accepted_commands[-1][0]
    assert 0.38 <= tripped_after <= 0.6
    assert emu.outputs == [0.0, 0.0] and emu.seen[-1][1] == [0.0, 0.0]
    assert emu.stats.watchdog_trips == 1
    assert await line.ask(p.thr_frame(4, [100, 100])) == p.nak_frame(4, "disarmed")
    assert (await line.ask(p.qry_frame(5))).startswith(b"$STA,5,WDT,1500,-1200,2.50,1.75*")
    assert await line.ask(p.arm_frame(6)) == p.ack_frame(6, "ARMED")
    assert await line.ask(p.thr_frame(7, [100, 100])) == p.ack_frame(7, "ARMED")
    assert emu.outputs == [0.1, 0.1]


async def test_heartbeat_keeps_watchdog_fed(emu, line) -> None:
    await line.ask(p.arm_frame(1))
    for seq in range(2, 12):
        assert await line.ask(p.thr_frame(seq, [100, 100])) == p.ack_frame(seq, "ARMED")
        await asyncio.sleep(0.1)  # paced like the 10 Hz host, for 1 s > the 0.4 s watchdog
    assert emu.state == "ARMED" and emu.stats.watchdog_trips == 0


async def test_disarm_zeroes(emu, line) -> None:
    await line.ask(p.arm_frame(1))
    await line.ask(p.thr_frame(2, [100, -100]))
    assert await line.ask(p.disarm_frame(3)) == p.ack_frame(3, "DISARMED")
    assert emu.outputs == [0.0, 0.0] and emu.seen[-1][1] == [0.0, 0.0]


async def test_silent_ignores_frames_but_watchdog_runs(emu, line) -> None:
    await line.ask(p.arm_frame(1))
    await line.ask(p.thr_frame(2, [100, 100]))
    emu.silent = True
    line.writer.write(p.thr_frame(3, [200, 200]))
    with pytest.raises(TimeoutError):
        await asyncio.wait_for(line.reader.readline(), 0.6)
    assert emu.state == "WDT" and emu.outputs == [0.0, 0.0]


async def test_pty_transport_with_pyserial(emu, controller) -> None:
    path = await controller.serve("pty")
    assert path.startswith("/dev/")

    def talk() -> list[bytes]:
        with serial.serial_for_url(path, baudrate=115200, timeout=ANSWER_S) as port:
            port.write(p.arm_frame(1) + p.thr_frame(2, [-1000, 1000]))
            return [port.readline(), port.readline()]

    replies = await asyncio.to_thread(talk)
    assert replies == [p.ack_frame(1, "ARMED"), p.ack_frame(2, "ARMED")]
    assert emu.outputs == [-1.0, 1.0]

    def reopen_and_read() -> bytes:
        with serial.serial_for_url(path, baudrate=115200, timeout=ANSWER_S) as port:
            port.write(p.qry_frame(3))
            port.readline()
            emu.inject(b"\x7fjunk\r\n")  # pyserial flushes input on open: inject while open
            return port.readline()

    assert await asyncio.to_thread(reopen_and_read) == b"\x7fjunk\r\n"


async def test_corrupt_replies_fault(emu, line) -> None:
    emu.corrupt_replies = 1
    with pytest.raises(p.ProtocolError, match="crc"):
        p.parse_reply(await line.ask(p.arm_frame(1)))
    assert p.parse_reply(await line.ask(p.arm_frame(2))).state == "ARMED"


def test_bad_constructor_arguments_name_the_field() -> None:
    with pytest.raises(ValueError, match=r"count.*17"):
        ThrusterControllerEmulator(17)
    with pytest.raises(ValueError, match=r"watchdog_s.*0"):
        ThrusterControllerEmulator(2, watchdog_s=0)
