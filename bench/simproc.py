"""Benchmark plumbing: the simulated rig in its own process, a baud-paced pty link, and
busy neighbours.

``RigSimProcess`` runs ``rig sim`` (the product's standalone simulator) as a
subprocess and parses its ready line, so the simulator never shares a core's GIL
or event loop with the clock being measured. ``PacedPtyLink`` puts a byte relay,
in its own process, between a client pty and the simulator's RTU pty that lets
bytes through no faster than a real half-duplex serial line would.
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import subprocess
import sys
import time
import tty
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Self

from daq.config import RigConfig

REPO = Path(__file__).resolve().parent.parent


def _fifo() -> None:
    """In a child before exec: SCHED_FIFO priority 5 (needs root/CAP_SYS_NICE; else no-op)."""
    with contextlib.suppress(OSError):
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(5))


class _ChildProcess:
    """A helper process (``proc``) stopped on ``close()`` or at the end of a ``with`` block."""

    proc: subprocess.Popen

    def close(self) -> None:
        """SIGTERM the process and wait for it (SIGKILL if it has not ended within 5 s)."""
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class BusyProcess(_ChildProcess):
    """A neighbour that keeps one core busy (``while True: pass``) for at most ``seconds``
    (it ends itself then, should the bench die first), at normal priority."""

    def __init__(self, seconds: float) -> None:
        code = f"import time\nend = time.monotonic() + {seconds!r}\n"
        code += "while time.monotonic() < end: pass"
        self.proc = subprocess.Popen([sys.executable, "-c", code])


@contextlib.contextmanager
def busy_neighbours(count: int, seconds: float) -> Iterator[list[BusyProcess]]:
    """``count`` :class:`BusyProcess` es for the ``with`` block (killed at its end)."""
    with contextlib.ExitStack() as stack:
        yield [stack.enter_context(BusyProcess(seconds)) for _ in range(count)]


class RigSimProcess(_ChildProcess):
    """``rig sim --modbus-port 0 [--rtu]`` in a subprocess; ``ready`` is its JSON line.

    ``realtime=True`` runs it SCHED_FIFO, as a stand-in for a PLC with its own CPU
    that does not compete with the host's other processes.
    """

    def __init__(self, *, rtu: bool = False, realtime: bool = False) -> None:
        code = "from api.cli.main import main; main()"
        args = [sys.executable, "-c", code, "sim", "--modbus-port", "0"]
        if rtu:
            args.append("--rtu")
        self.proc = subprocess.Popen(
            args,
            cwd=REPO,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=_fifo if realtime else None,
        )
        line = self.proc.stdout.readline() if self.proc.stdout else ""
        if not line:
            err = self.proc.stderr.read() if self.proc.stderr else ""
            raise RuntimeError(f"rig sim did not start: {err.strip()[-500:]}")
        self.ready: dict[str, Any] = json.loads(line)

    def connection_rig(self, rig: RigConfig, **modbus: Any) -> RigConfig:
        """``rig`` with [modbus] pointing at the running simulator (plus overrides)."""
        mb = self.ready["modbus"]
        if mb["transport"] == "tcp":
            update: dict[str, Any] = {"transport": "tcp", "host": mb["host"], "port": mb["port"]}
        else:
            update = {"transport": "rtu", "serial_port": mb["serial_port"]}
        update.update(modbus)
        return rig.model_copy(update={"modbus": rig.modbus.model_copy(update=update)})


def _relay(device_path: str, bytes_per_s: float, frame_gap_s: float = 0.0) -> None:
    """Child process: forward bytes between a new pty and ``device_path``, paced; each
    chunk (a frame: Modbus writes whole frames) waits ``frame_gap_s`` of line silence."""
    master, slave = os.openpty()
    tty.setraw(slave)
    device = os.open(device_path, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(device)
    sys.stdout.write(os.ttyname(slave) + "\n")
    sys.stdout.flush()
    wire_free_at = 0.0  # half duplex: one wire for both directions
    peer = {master: device, device: master}
    while True:
        ready, _, _ = select.select([master, device], [], [], 1.0)
        for src in ready:
            try:
                data = os.read(src, 4096)
            except OSError:
                return
            if not data:
                continue
            # The chunk is on the receiver's side once its last byte has crossed the wire.
            now = time.monotonic()
            wire_free_at = max(now, wire_free_at + frame_gap_s) + len(data) / bytes_per_s
            while (left := wire_free_at - time.monotonic()) > 0:
                if left > 0.0005:
                    time.sleep(left - 0.0004)
            os.write(peer[src], data)


class PacedPtyLink(_ChildProcess):
    """A pty (``client_path``) joined to ``device_path`` through a line of ``baudrate`` 8N1."""

    def __init__(
        self,
        device_path: str,
        *,
        baudrate: int = 115200,
        bits_per_byte: int = 10,
        frame_gap_s: float = 0.0,
        realtime: bool = False,
    ) -> None:
        self.bytes_per_s = baudrate / bits_per_byte
        self.proc = subprocess.Popen(
            [
                sys.executable,
                __file__,
                "relay",
                device_path,
                str(self.bytes_per_s),
                str(frame_gap_s),
            ],
            stdout=subprocess.PIPE,
            text=True,
            preexec_fn=_fifo if realtime else None,
        )
        line = self.proc.stdout.readline() if self.proc.stdout else ""
        if not line.strip():
            self.close()
            raise RuntimeError(f"paced pty link to {device_path} did not start")
        self.client_path: str = line.strip()


if __name__ == "__main__" and len(sys.argv) == 5 and sys.argv[1] == "relay":
    _relay(sys.argv[2], float(sys.argv[3]), float(sys.argv[4]))
