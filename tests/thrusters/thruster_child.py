"""A driver process for the zero-on-exit tests: ``python thruster_child.py URL MODE``.

Opens the driver against the controller at URL, arms, commands 50 % thrust and sends
heartbeats at 10 Hz. MODE ``signals``: runs until SIGINT/SIGTERM (the driver's handlers
zero the thrusters); ``atexit``: exits after 0.5 s without closing the driver.

It paces the heartbeat as a real-time rig session does (``daq.session``, ``daq.priority``):
its loop real-time at the clock's priority, the line's I/O thread at
``THRUSTER_LINK_PRIORITY``, where the OS allows. At normal priority, beside busy processes,
its 0.1 s sleep ended up to 0.26 s late and two heartbeats went 0.59 s apart: the
controller's watchdog rightly tripped, on a host scheduled as no session runs one.
"""

from __future__ import annotations

import asyncio
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from daq.config import load_rig
from daq.priority import set_realtime, thruster_link_realtime
from thrusters.driver import ThrusterDriver


async def main(url: str, mode: str) -> None:
    rig = load_rig()
    drv = ThrusterDriver(rig.thrusters, rig.limits, port=url)
    set_realtime(warn=False)
    await drv.open(io_thread_setup=thruster_link_realtime)
    if mode == "signals":
        drv.install_signal_handlers()
    await drv.arm()
    await drv.command([0.5, 0.5])
    print("armed", flush=True)
    for _ in range(5 if mode == "atexit" else 10_000):
        await asyncio.sleep(0.1)  # paced like the 10 Hz host: heartbeats feed the watchdog
        await drv.heartbeat()
    if mode == "atexit":
        sys.exit(3)  # the driver is still open: only the atexit fallback zeroes


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1], sys.argv[2]))
