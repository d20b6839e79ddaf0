"""A lab's PLC that is neither the simulator nor built on pymodbus, in a process of its own.

pyModbusTCP's ``ModbusServer`` (its own Modbus TCP implementation) serves the register
map of a weight-driven carriage: the encoder a uint32 in holding registers 10-11 (high word
first), the brake release coil 3. The PLC's program advances the encoder at
``CART_SPEED_M_S`` while the coil is set.

A real PLC answers on a CPU of its own, so this one runs in its own process, real-time just
below the rig's clock where the OS allows (``daq.priority.SIMULATOR_PRIORITY``, as the
simulated rig and the fault proxies run). It used to be a thread of the test process at
normal priority: beside two busy loops and another real-time test it waited up to 110 ms for
a CPU with a request in its socket (``timeout_s`` is 0.05 s, so each such wait cost a poll)
and once failed five polls in a row (pymodbus then drops the link); a whole-suite run beside
a busy process lost six polls at the start of a tow, which the tow rightly aborts for.

:class:`CartPlc` starts it (``python -m tests.support.cart_plc``) and talks to it over its
stdin and stdout, one line each way: the process prints its port, then answers ``reset``
with ``ok`` and ``state`` with a JSON object; it ends when its stdin closes.
"""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

#: The carriage's speed once the brake lets go (m/s) and the encoder's resolution (m/count).
CART_SPEED_M_S = 0.5
METRES_PER_COUNT = 1e-5
#: Where the PLC's program keeps the encoder count and the brake release.
ENCODER_ADDRESS = 10
RELEASE_COIL = 3

ROOT = Path(__file__).resolve().parents[2]


class CartPlc:
    """The PLC process, seen from a test: ``port``, ``reset()`` (the operator pushes the
    carriage back to the start), ``state()`` and ``stop()``."""

    def __init__(self) -> None:
        self._process: subprocess.Popen[str] | None = None
        self.port = 0

    def start(self) -> None:
        self._process = subprocess.Popen(
            [sys.executable, "-m", "tests.support.cart_plc"],
            cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            text=True,
        )  # fmt: skip
        self.port = int(self._ask(None))

    def reset(self) -> None:
        """The operator pushes the carriage back to the start (done when this returns)."""
        assert self._ask("reset") == "ok"

    def state(self) -> dict[str, bool]:
        """``released_ever``: the brake was released; ``braked_after_release``: and then
        engaged again."""
        return json.loads(self._ask("state"))

    def stop(self) -> None:
        process, self._process = self._process, None
        if process is None:
            return
        assert process.stdin is not None
        with contextlib.suppress(BrokenPipeError):
            process.stdin.close()
        try:
            process.wait(5)
        finally:
            if process.returncode is None:
                process.kill()
                process.wait()
            for pipe in (process.stdout, process.stderr):
                if pipe is not None:
                    pipe.close()

    def _ask(self, command: str | None) -> str:
        """Send ``command`` (None: nothing) and return the PLC's next line."""
        process = self._process
        assert process is not None and process.stdin is not None and process.stdout is not None
        if command is not None:
            process.stdin.write(command + "\n")
            process.stdin.flush()
        line = process.stdout.readline()
        if not line:
            process.wait(5)
            err = process.stderr.read() if process.stderr else ""
            raise RuntimeError(f"the cart PLC ended (exit {process.returncode}): {err}")
        return line.strip()


def _as_device() -> None:
    """Run this whole process real-time where the OS allows: the policy is set without
    ``SCHED_RESET_ON_FORK`` (unlike ``daq.priority.set_realtime``), so the server's threads,
    started later, one per connection, inherit it."""
    from daq.priority import SIMULATOR_PRIORITY

    with contextlib.suppress(OSError):
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(SIMULATOR_PRIORITY))


def _serve() -> None:
    from pyModbusTCP.server import DataBank, ModbusServer

    _as_device()
    bank = DataBank()
    lock = threading.Lock()
    position = [0.0]
    released_ever = threading.Event()
    braked_after_release = threading.Event()
    stop = threading.Event()

    def write_position(metres: float) -> None:
        position[0] = metres
        counts = round(metres / METRES_PER_COUNT)
        bank.set_holding_registers(ENCODER_ADDRESS, [counts >> 16, counts & 0xFFFF])

    def scan() -> None:  # the PLC's program, one scan per 5 ms
        last = time.monotonic()
        while not stop.wait(0.005):
            now = time.monotonic()
            released = bool(bank.get_coils(RELEASE_COIL, 1)[0])
            with lock:
                if released:
                    released_ever.set()
                    write_position(position[0] + CART_SPEED_M_S * (now - last))
                elif released_ever.is_set():
                    braked_after_release.set()
            last = now

    write_position(0.0)
    server = ModbusServer(host="127.0.0.1", port=0, no_block=True, data_bank=bank)
    server.start()
    program = threading.Thread(target=scan, name="cart-plc-scan", daemon=True)
    program.start()
    print(server._service.server_address[1], flush=True)  # bound by start() (port 0: any free)
    try:
        for line in sys.stdin:
            command = line.strip()
            if command == "reset":
                with lock:
                    write_position(0.0)
                print("ok", flush=True)
            elif command == "state":
                flags = {
                    "released_ever": released_ever.is_set(),
                    "braked_after_release": braked_after_release.is_set(),
                }
                print(json.dumps(flags), flush=True)
            else:
                raise ValueError(f"unknown command {command!r}")
    finally:
        # the server's threads are daemons: this process's exit ends them and closes their
        # sockets (its stop() would wait out the serving loop's 0.5 s poll first)
        stop.set()
        program.join(5)


if __name__ == "__main__":
    _serve()
