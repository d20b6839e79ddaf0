"""Simulated thruster controller speaking the line protocol over a pty or TCP.

It behaves like the real controller board (see ``docs/thruster-protocol.md``): it
validates every frame, rejects (never clamps) out-of-range commands, refuses
replayed sequence numbers, and its watchdog zeroes all outputs and latches ``WDT``
when no valid frame has arrived for ``watchdog_s`` while armed.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import time
import tty
from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass, field

from thrusters import protocol as p

log = logging.getLogger(__name__)


@dataclass
class EmulatorStats:
    """Counters of what the controller received and answered."""

    frames_ok: int = 0
    crc_errors: int = 0
    garbage_lines: int = 0
    acks: int = 0
    queries: int = 0
    watchdog_trips: int = 0
    naks: Counter[str] = field(default_factory=Counter)
    #: The last 1000 accepted THR frames as (monotonic time, commands in per mille).
    accepted_commands: deque[tuple[float, tuple[int, ...]]] = field(
        default_factory=lambda: deque(maxlen=1000)
    )


class ThrusterControllerEmulator:
    """The simulated controller of ``count`` thrusters.

    ``on_outputs(fractions)`` is called whenever the outputs change (including the
    watchdog zeroing them); ``telemetry()`` gives (rpm, current_a) per thruster for
    QRY answers (zeros when None). Fault injection: ``silent = True`` makes it ignore
    everything it receives (the watchdog keeps running); ``inject(raw)`` writes raw
    bytes toward the host; ``corrupt_replies = n`` spoils the CRC of the next n replies.
    """

    def __init__(
        self,
        count: int,
        *,
        on_outputs: Callable[[list[float]], None] = lambda f: None,
        telemetry: Callable[[], list[tuple[float, float]]] | None = None,
        watchdog_s: float = 0.4,
    ) -> None:
        if not 1 <= count <= 16:
            raise ValueError(f"count: thruster count must be 1…16, got {count!r}")
        if not watchdog_s > 0:
            raise ValueError(f"watchdog_s: must be > 0 s, got {watchdog_s!r}")
        self.count = count
        self.on_outputs = on_outputs
        self.telemetry = telemetry
        self.watchdog_s = watchdog_s
        self.state = "DISARMED"
        self.outputs: list[float] = [0.0] * count
        self.stats = EmulatorStats()
        self.silent = False
        self.corrupt_replies = 0
        self._last_thr_seq: int | None = None
        self._watchdog: asyncio.TimerHandle | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._master_fd: int | None = None
        self._slave_fd: int | None = None
        self._pty_buffer = b""
        self._server: asyncio.base_events.Server | None = None
        self._writers: set[asyncio.StreamWriter] = set()

    # ---- transports -------------------------------------------------------------------

    async def start_pty(self) -> str:
        """Serve on a new pty pair; returns the slave device path for pyserial."""
        self._loop = asyncio.get_running_loop()
        master, slave = os.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)
        self._master_fd, self._slave_fd = master, slave  # keep slave open: no EIO on reopen
        self._loop.add_reader(master, self._on_pty_readable)
        return os.ttyname(slave)

    async def start_tcp(self, host: str = "127.0.0.1", port: int = 0) -> str:
        """Serve over TCP; returns a pyserial URL ``socket://host:port``."""
        self._loop = asyncio.get_running_loop()
        self._server = await asyncio.start_server(self._on_client, host, port)
        bound = self._server.sockets[0].getsockname()
        return f"socket://{bound[0]}:{bound[1]}"

    async def stop(self) -> None:
        """Stop serving (outputs are left as they are; the simulated rig decides)."""
        if self._watchdog:
            self._watchdog.cancel()
            self._watchdog = None
        if self._master_fd is not None and self._loop is not None:
            self._loop.remove_reader(self._master_fd)
            os.close(self._master_fd)
            os.close(self._slave_fd)  # type: ignore[arg-type]
            self._master_fd = self._slave_fd = None
        if self._server is not None:
            self._server.close()
            for w in list(self._writers):
                w.close()
            with contextlib.suppress(Exception):
                await self._server.wait_closed()
            self._server = None

    def inject(self, raw: bytes) -> None:
        """Send raw bytes (garbage, half frames) toward every connected host."""
        self._write_pty(raw)
        for w in list(self._writers):
            w.write(raw)

    def exchange(self, raw: bytes) -> bytes:
        """In process (no port): handle the complete lines of ``raw`` as if they had come
        down the line and return what the controller answers (``thrusters.inprocess_link``)."""
        replies = _Collected()
        self._feed(raw, replies)  # type: ignore[arg-type]
        return bytes(replies.data)

    # ---- pty side ---------------------------------------------------------------------

    def _on_pty_readable(self) -> None:
        try:
            data = os.read(self._master_fd, 4096)  # type: ignore[arg-type]
        except (BlockingIOError, InterruptedError):
            return
        except OSError:  # EIO: cannot happen while we hold the slave, but never crash
            return
        self._pty_buffer = self._feed(self._pty_buffer + data, None)

    def _write_pty(self, raw: bytes) -> None:
        if self._master_fd is None:
            return
        try:
            os.write(self._master_fd, raw)
        except (BlockingIOError, OSError) as err:  # host not reading: drop like a UART would
            log.debug("thruster emulator: pty write dropped: %s", err)

    # ---- TCP side ---------------------------------------------------------------------

    async def _on_client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self._writers.add(writer)
        buffer = b""
        try:
            while data := await reader.read(4096):
                buffer = self._feed(buffer + data, writer)
        except (ConnectionError, asyncio.CancelledError):
            pass
        finally:
            self._writers.discard(writer)
            writer.close()

    # ---- line handling ----------------------------------------------------------------

    def _feed(self, buffer: bytes, writer: asyncio.StreamWriter | None) -> bytes:
        """Handle every complete line in ``buffer``; return the unfinished rest."""
        *lines, rest = buffer.split(b"\n")
        for line in lines:
            if not self.silent:
                self._handle_line(line, writer)
        if len(rest) > p.MAX_LINE_BYTES:  # noise without a line end: resync at the last '$'
            self.stats.garbage_lines += 1
            start = rest.rfind(b"$")
            rest = rest[start:] if start > 0 and len(rest) - start <= p.MAX_LINE_BYTES else b""
        return rest

    def _handle_line(self, line: bytes, writer: asyncio.StreamWriter | None) -> None:
        line = line.rstrip(b"\r")
        if not line:
            return
        self._watchdog_overdue()
        if b"$" not in line:
            self.stats.garbage_lines += 1
            return
        try:
            frame = p.parse_frame(line)
        except p.ProtocolError as err:
            if err.reason == "crc":
                self.stats.crc_errors += 1
            log.debug("thruster emulator: %s", err)
            self._nak(err.seq, err.reason, writer)
            return
        seq = p.frame_seq(frame)
        args = frame.fields[1:]
        if frame.kind == "THR":
            self._on_thr(seq, args, writer)
        elif frame.kind in ("ARM", "DISARM", "QRY") and args:
            self._nak(seq, "malformed", writer)
        elif frame.kind == "ARM":
            self.stats.frames_ok += 1
            self.state = "ARMED"
            self._last_thr_seq = None  # a deliberate re-arm starts a new sequence window
            self._feed_watchdog()
            self._ack(seq, writer)
        elif frame.kind == "DISARM":
            self.stats.frames_ok += 1
            self._set_state_zero("DISARMED")
            self._ack(seq, writer)
        elif frame.kind == "QRY":
            self.stats.frames_ok += 1
            self.stats.queries += 1
            telemetry = self.telemetry() if self.telemetry else [(0.0, 0.0)] * self.count
            self._reply(p.sta_frame(seq, self.state, list(telemetry)), writer)
        else:  # a reply kind sent to the controller
            self._nak(seq, "malformed", writer)

    def _on_thr(self, seq: int, args: tuple[str, ...], writer: asyncio.StreamWriter | None) -> None:
        try:
            commands = [int(a) for a in args]
        except ValueError:
            commands = []
        if len(commands) != self.count or len(args) != self.count:
            self._nak(seq, "malformed", writer)
            return
        if any(not p.COMMAND_MIN <= c <= p.COMMAND_MAX for c in commands):
            self._nak(seq, "range", writer)
            return
        if self.state != "ARMED":
            self._nak(seq, "disarmed", writer)
            return
        if self._last_thr_seq is not None and not p.seq_is_newer(seq, self._last_thr_seq):
            self._nak(seq, "stale", writer)
            return
        self.stats.frames_ok += 1
        self._last_thr_seq = seq
        self.stats.accepted_commands.append((time.monotonic(), tuple(commands)))
        self._feed_watchdog()
        self._set_outputs([c / 1000 for c in commands])
        self._ack(seq, writer)

    # ---- state ------------------------------------------------------------------------

    def _feed_watchdog(self) -> None:
        if self._watchdog:
            self._watchdog.cancel()
        loop = self._loop or asyncio.get_running_loop()
        self._watchdog = loop.call_later(self.watchdog_s, self._watchdog_expired)

    def _watchdog_overdue(self) -> None:
        """A frame arriving after the watchdog's time finds it tripped, even when the loop
        it shares (simulated time, a loaded host) has not yet run the timer."""
        loop = self._loop or asyncio.get_running_loop()
        if self._watchdog is not None and self._watchdog.when() <= loop.time():
            self._watchdog.cancel()
            self._watchdog_expired()

    def _watchdog_expired(self) -> None:
        self._watchdog = None
        if self.state == "ARMED":
            self.stats.watchdog_trips += 1
            log.warning("thruster emulator: watchdog tripped, outputs zeroed (state WDT)")
            self._set_state_zero("WDT")

    def _set_state_zero(self, state: str) -> None:
        self.state = state
        if self._watchdog:
            self._watchdog.cancel()
            self._watchdog = None
        self._set_outputs([0.0] * self.count)

    def _set_outputs(self, fractions: list[float]) -> None:
        if fractions == self.outputs:
            return
        self.outputs = fractions
        try:
            self.on_outputs(list(fractions))
        except Exception:
            log.exception("thruster emulator: on_outputs callback failed")

    # ---- replies ----------------------------------------------------------------------

    def _ack(self, seq: int, writer: asyncio.StreamWriter | None) -> None:
        self.stats.acks += 1
        self._reply(p.ack_frame(seq, self.state), writer)

    def _nak(self, seq: int | None, reason: str, writer: asyncio.StreamWriter | None) -> None:
        self.stats.naks[reason] += 1
        self._reply(p.nak_frame(seq, reason), writer)

    def _reply(self, raw: bytes, writer: asyncio.StreamWriter | None) -> None:
        if self.corrupt_replies > 0:
            self.corrupt_replies -= 1
            raw = raw[:-6] + (b"0000" if raw[-6:-2] != b"0000" else b"FFFF") + b"\r\n"
        self._send_raw(raw, writer)

    def _send_raw(self, raw: bytes, writer: asyncio.StreamWriter | None) -> None:
        if writer is None:
            self._write_pty(raw)
        else:
            writer.write(raw)


class _Collected:
    """Stands in for a stream writer: keeps the bytes written to it."""

    def __init__(self) -> None:
        self.data = bytearray()

    def write(self, raw: bytes) -> None:
        self.data += raw
