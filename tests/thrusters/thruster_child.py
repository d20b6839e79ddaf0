"""A driver process for the zero-on-exit tests: ``python thruster_child.py URL MODE``.

Opens the driver against the controller at URL, arms, commands 50 % thrust and sends
heartbeats at 10 Hz. MODE ``signals``: runs until SIGINT/SIGTERM (the driver's handlers
zero the thrusters); ``atexit``: exits after 0.5 s without closing the driver.
"""

from __future__ import annotations

import asyncio
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from daq.config import load_rig
from thrusters.driver import ThrusterDriver


async def main(url: str, mode: str) -> None:
    rig = load_rig()
    drv = ThrusterDriver(rig.thrusters, rig.limits, port=url)
    await drv.open()
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
