"""Blocking request/reply over a serial line (pyserial): one frame out, its reply back.

Used from a single worker thread by ``ThrusterDriver``. Anything on the line that is not
the expected reply (garbage, CRC errors, replies to other sequence numbers) is counted and
logged, never raised.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

import serial
from serial.urlhandler import protocol_socket

from thrusters import protocol as p

log = logging.getLogger(__name__)

#: Longest single blocking read; bounds how late a reply deadline can be noticed.
READ_SLICE_S = 0.01


@dataclass
class LinkStats:
    """What the host sent and what came back."""

    sent: int = 0
    acked: int = 0
    queries_answered: int = 0
    naks: Counter[str] = field(default_factory=Counter)
    timeouts: int = 0
    #: Lines that are not frames at all (no ``$``, bad syntax, over-long).
    garbage_lines: int = 0
    #: Frames whose CRC does not match.
    corrupt_lines: int = 0
    #: Valid replies answering another sequence number (late or unsolicited).
    unexpected_replies: int = 0
    io_errors: int = 0
    #: Times the port was reopened after an I/O error (adapter unplugged, socket dropped).
    reconnects: int = 0


class _SocketPort(protocol_socket.Serial):
    """pyserial's ``socket://`` port without the 0.3 s sleep its ``close`` takes "in case of
    quick reconnects": this link reconnects at most once per frame and the controller's
    server accepts at once, so the sleep only held up every close of the simulated rig's
    thruster line (each ``rig serve`` stop, each ``rig tow``, each service a test stops)
    and each drop of the line after an I/O error."""

    def close(self) -> None:
        sock: socket.socket | None = getattr(self, "_socket", None)  # pyserial is untyped
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.shutdown(socket.SHUT_RDWR)
            sock.close()
        self._socket = None
        self.is_open = False


def open_serial_port(url: str, baudrate: int) -> serial.SerialBase:
    """A pyserial port for a device path or URL, reading in slices of ``READ_SLICE_S``."""
    if url.startswith("socket://"):
        port = _SocketPort(None, baudrate=baudrate, timeout=READ_SLICE_S, write_timeout=0.5)
        port.port = url  # as serial_for_url does
        port.open()
        return port
    return serial.serial_for_url(url, baudrate=baudrate, timeout=READ_SLICE_S, write_timeout=0.5)


class SerialLink:
    """A pyserial port (device path or URL such as ``socket://host:port``) carrying frames.

    ``open_port`` and ``clock`` are the transport seam: tests pass an in-memory port (any
    object with pyserial's ``read``/``write``/``flush``/``in_waiting``/
    ``reset_input_buffer``/``close``) and the clock it advances, so conversations and reply
    timeouts run without a pty or real waiting."""

    #: I/O blocks: the driver runs it on its worker thread (an in-process link does not).
    blocking = True

    def __init__(
        self,
        url: str,
        baudrate: int,
        reply_timeout_s: float,
        *,
        open_port: Callable[[str, int], serial.SerialBase] = open_serial_port,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.url = url
        self.baudrate = baudrate
        self.reply_timeout_s = reply_timeout_s
        self._open_port = open_port
        self._clock = clock
        self.stats = LinkStats()
        self._port: serial.SerialBase | None = None
        self._wanted = False
        self._rx = b""
        #: Host monotonic times just before the last frame went out and when its reply was
        #: read, stamped in the thread doing the I/O (None: no reply). A caller on an event
        #: loop resumes later than that on a loaded host; these times do not move with it.
        self.last_bracket: tuple[float, float] | None = None

    @property
    def is_open(self) -> bool:
        """True between ``open()`` and ``close()``, even while the line is down."""
        return self._wanted

    def open(self) -> None:
        """Open the port and discard anything already waiting."""
        self._connect()
        self._wanted = True

    def _connect(self) -> None:
        self._port = self._open_port(self.url, self.baudrate)
        self._port.reset_input_buffer()
        self._rx = b""

    def close(self) -> None:
        self._wanted = False
        self._drop_port()

    def _drop_port(self) -> None:
        port, self._port = self._port, None
        if port is not None:
            try:
                port.close()
            except (OSError, serial.SerialException) as err:
                log.debug("thruster link: close failed: %s", err)

    async def wait_on_loop(self) -> None:
        """What a non-blocking link's last ``transact`` owes the caller in time (its reply
        timeout), waited on the event loop; a blocking link waited in ``transact``."""

    def write_raw(self, raw: bytes) -> None:
        """Write bytes without waiting for anything (the at-exit fallback)."""
        if self._port is None:
            return
        self._port.write(raw)
        self._port.flush()

    def transact(self, raw: bytes, seq: int) -> p.Reply | None:
        """Send one frame and return the reply carrying ``seq`` (or a NAK without a
        readable seq); None on timeout or a broken line."""
        if not self._wanted:
            raise serial.SerialException(f"thruster link {self.url} is not open")
        self.last_bracket = None
        try:
            if self._port is None:  # lost after an I/O error: one reopen attempt per frame
                self._connect()
                self.stats.reconnects += 1
                log.warning("thruster link %s: reconnected", self.url)
            assert self._port is not None
            self._drain_stray()
            t_sent = time.monotonic()
            self._port.write(raw)
            self.stats.sent += 1
            deadline = self._clock() + self.reply_timeout_s
            while (line := self._read_line(deadline)) is not None:
                reply = self._classify(line, seq)
                if reply is not None:
                    self.last_bracket = (t_sent, time.monotonic())
                    return reply
        except (OSError, serial.SerialException) as err:
            self.stats.io_errors += 1
            log.warning("thruster link %s: I/O error: %s", self.url, err)
            self._drop_port()
            return None
        self.stats.timeouts += 1
        log.warning(
            "thruster link %s: no reply to %r within %.3f s", self.url, raw, self.reply_timeout_s
        )
        return None

    def _classify(self, line: bytes, seq: int) -> p.Reply | None:
        """The reply if ``line`` answers ``seq``; otherwise count it and return None."""
        try:
            reply = p.parse_reply(line)
        except p.ProtocolError as err:
            if err.reason == "crc":
                self.stats.corrupt_lines += 1
            else:
                self.stats.garbage_lines += 1
            log.warning("thruster link %s: dropped line %r (%s)", self.url, line[:60], err)
            return None
        if reply.seq is not None and reply.seq != seq:
            self.stats.unexpected_replies += 1
            log.warning(
                "thruster link %s: reply for seq %s while waiting for %s", self.url, reply.seq, seq
            )
            return None
        if reply.kind == "ACK":
            self.stats.acked += 1
        elif reply.kind == "NAK":
            self.stats.naks[reply.reason or "?"] += 1
            log.warning("thruster link %s: NAK %s for seq %s", self.url, reply.reason, seq)
        else:
            self.stats.queries_answered += 1
        return reply

    def _read_line(self, deadline: float) -> bytes | None:
        assert self._port is not None
        late_read = False
        while True:
            while b"\n" not in self._rx:
                if self._clock() >= deadline:
                    # A reply that arrived while this thread was not scheduled (host under
                    # load) is still on time: take what is waiting once, then give up.
                    if late_read or not self._port.in_waiting:
                        return None
                    late_read = True
                chunk = self._port.read(max(1, self._port.in_waiting))
                self._rx += chunk
                if b"\n" not in self._rx and len(self._rx) > p.MAX_LINE_BYTES:
                    self._rx = self._resync(self._rx)
            line, _, self._rx = self._rx.partition(b"\n")
            if len(line) <= p.MAX_LINE_BYTES:
                return line
            # Over-long garbage and a frame arrived in one read: the same resync as above,
            # however the bytes were split into reads.
            if line := self._resync(line):
                return line

    def _resync(self, rx: bytes) -> bytes:
        """Drop an over-long run of bytes without a line end, keeping a frame that may
        have started at its last ``$``."""
        start = rx.rfind(b"$")
        keep = rx[start:] if start > 0 and len(rx) - start <= p.MAX_LINE_BYTES else b""
        self.stats.garbage_lines += 1
        log.warning(
            "thruster link %s: dropped %d bytes without a line end", self.url, len(rx) - len(keep)
        )
        return keep

    def _drain_stray(self) -> None:
        """Count and drop complete lines that arrived while nobody was waiting."""
        assert self._port is not None
        waiting = self._port.in_waiting
        if waiting:
            self._rx += self._port.read(waiting)
        while b"\n" in self._rx:
            line, _, self._rx = self._rx.partition(b"\n")
            if line.strip():
                self._classify(line, -1)
