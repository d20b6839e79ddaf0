"""The simulated thruster controller in a process of its own: ``python controller_process.py
pty|socket`` (``ControllerProcess`` in thruster_helpers.py starts it).

The real board answers and keeps its watchdog on a CPU of its own. A thread of the test
process (even real-time) still waits for the GIL, which a normal-priority thread of that
process can hold while a loaded machine keeps it off the CPU: beside busy processes such a
controller took a frame up to 0.2 s late. So this one runs alone, real-time just below the
rig's clock where the OS allows (``daq.priority.SIMULATOR_PRIORITY``), as the cart PLC does
(tests/support/cart_plc.py). It prints where it serves, then answers each ``state`` line on
its stdin with one JSON line (state, outputs, acks, watchdog trips, the accepted commands and
every change of its outputs, with their monotonic times); it ends when its stdin closes.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from daq.priority import SIMULATOR_PRIORITY
from thrusters.emulator import ThrusterControllerEmulator


async def serve(transport: str) -> None:
    with contextlib.suppress(OSError):  # refused: it runs at normal priority
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(SIMULATOR_PRIORITY))
    seen: list[tuple[float, list[float]]] = []
    emu = ThrusterControllerEmulator(2, on_outputs=lambda f: seen.append((time.monotonic(), f)))
    url = await (emu.start_pty() if transport == "pty" else emu.start_tcp())
    print(url, flush=True)
    loop = asyncio.get_running_loop()
    done = loop.create_future()

    def on_command() -> None:
        line = sys.stdin.readline()
        if not line:
            loop.remove_reader(sys.stdin.fileno())
            done.set_result(None)
            return
        assert line.strip() == "state", line
        state = {
            "state": emu.state,
            "outputs": emu.outputs,
            "acks": emu.stats.acks,
            "watchdog_trips": emu.stats.watchdog_trips,
            "accepted_commands": list(emu.stats.accepted_commands),
            "seen": seen,
        }
        print(json.dumps(state), flush=True)

    loop.add_reader(sys.stdin.fileno(), on_command)
    await done
    await emu.stop()


if __name__ == "__main__":
    asyncio.run(serve(sys.argv[1]))
