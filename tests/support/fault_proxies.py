"""Fault-injecting proxies for end-to-end tests: a pty↔pty proxy on the thruster serial line
and a TCP proxy in front of the PLC that can be cut. They sit between real processes; the
host's driver is not touched."""

from __future__ import annotations

import contextlib
import os
import select
import socket
import threading
import time
import tty

from daq.priority import SIMULATOR_PRIORITY, set_realtime

#: What the serial proxy does with each line in one direction.
MODES = ("pass", "drop", "garbage")


def _garbage(line: bytes) -> bytes:
    """Noise of the line's length with no frame in it (no ``$``)."""
    return bytes((b * 7 + 3) % 94 + 33 for b in line.rstrip(b"\r\n")).replace(b"$", b"%") + b"\r\n"


def _as_device() -> None:
    """A proxy stands in for the rig's wiring: its thread runs real-time where the OS allows,
    as the simulated devices behind it do (a loaded test box must not delay the bytes)."""
    set_realtime(SIMULATOR_PRIORITY, warn=False)


class SerialFaultProxy:
    """Forwards lines between a new pty (``path``, for the host) and the controller's pty
    ``controller``, doing to each line what ``to_controller`` / ``to_host`` say
    (``MODES``; ``to_host="garbage"`` also sends the host noise for each line it writes,
    so a controller that hears only noise still leaves noise on the line). Every line the
    host wrote is kept in ``from_host`` as ``(monotonic time, line)``, whatever was done
    with it."""

    def __init__(self, controller: str) -> None:
        self._up = os.open(controller, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self._up)
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.path = os.ttyname(self._slave)
        self.to_controller = "pass"
        self.to_host = "pass"
        self.from_host: list[tuple[float, bytes]] = []
        self._lock = threading.Lock()
        self._stop_r, self._stop_w = os.pipe()
        self._thread = threading.Thread(target=self._run, name="serial-fault-proxy", daemon=True)
        self._thread.start()

    def set(self, *, to_controller: str | None = None, to_host: str | None = None) -> float:
        """Change the faults; returns the monotonic time they took effect."""
        assert to_controller in (None, *MODES) and to_host in (None, *MODES)
        with self._lock:
            self.to_controller = to_controller or self.to_controller
            self.to_host = to_host or self.to_host
            return time.monotonic()

    def first_zero_after(self, t: float) -> float | None:
        """When the host first asked for zero thrust (an all-zero THR or a DISARM) after
        ``t``, as the proxy saw it on the wire; None if it never did."""
        for t_line, line in list(self.from_host):
            if t_line < t:
                continue
            head = line.split(b"*")[0].split(b",")
            if head[0] == b"$DISARM" or (head[0] == b"$THR" and all(int(c) == 0 for c in head[2:])):
                return t_line
        return None

    def close(self) -> None:
        os.write(self._stop_w, b"x")
        self._thread.join(5)
        for fd in (self._up, self._master, self._slave, self._stop_r, self._stop_w):
            os.close(fd)

    def _run(self) -> None:
        _as_device()
        pending = {self._master: b"", self._up: b""}
        while True:
            ready, _, _ = select.select([*pending, self._stop_r], [], [])
            if self._stop_r in ready:
                return
            for fd in ready:
                try:
                    data = os.read(fd, 4096)
                except OSError:  # the other end went away (EIO): nothing more comes from it
                    data = b""
                if not data:
                    del pending[fd]
                    continue
                pending[fd] += data
                while b"\n" in pending[fd]:
                    line, _, pending[fd] = pending[fd].partition(b"\n")
                    self._forward(fd, line + b"\n")

    def _forward(self, source: int, line: bytes) -> None:
        from_host = source == self._master
        with self._lock:
            mode = self.to_controller if from_host else self.to_host
            if from_host:
                self.from_host.append((time.monotonic(), line))
                if self.to_host == "garbage":  # a noisy line: noise reaches the host too
                    self._write(self._master, _garbage(line))
        if mode == "drop":
            return
        if mode == "garbage":
            line = _garbage(line)
        self._write(self._up if from_host else self._master, line)

    @staticmethod
    def _write(fd: int, data: bytes) -> None:
        with contextlib.suppress(OSError):  # that side is gone: lost, as on a cut cable
            os.write(fd, data)


class TcpCutProxy:
    """Forwards TCP connections on ``port`` to ``target``; ``cut()`` closes every
    connection and the listener, as if the device behind it had died."""

    def __init__(self, target: tuple[str, int]) -> None:
        self.target = target
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.port = self._listener.getsockname()[1]
        self._sockets: list[socket.socket] = []
        self._lock = threading.Lock()
        self._cut = False
        threading.Thread(target=self._accept, name="tcp-cut-proxy", daemon=True).start()

    def cut(self) -> float:
        """Close everything; returns the monotonic time of the cut."""
        with self._lock:
            self._cut = True
            t = time.monotonic()
            for s in [self._listener, *self._sockets]:
                with contextlib.suppress(OSError):
                    s.shutdown(socket.SHUT_RDWR)
                s.close()
        return t

    def close(self) -> None:
        if not self._cut:
            self.cut()

    def _accept(self) -> None:
        _as_device()
        while True:
            try:
                client, _ = self._listener.accept()
            except OSError:
                return
            upstream = socket.create_connection(self.target)
            with self._lock:
                if self._cut:
                    client.close()
                    upstream.close()
                    return
                self._sockets += [client, upstream]
            for a, b in ((client, upstream), (upstream, client)):
                threading.Thread(target=self._pipe, args=(a, b), daemon=True).start()

    @staticmethod
    def _pipe(src: socket.socket, dst: socket.socket) -> None:
        _as_device()
        try:
            while data := src.recv(4096):
                dst.sendall(data)
        except OSError:
            pass
        for s in (src, dst):
            with contextlib.suppress(OSError):
                s.shutdown(socket.SHUT_RDWR)
