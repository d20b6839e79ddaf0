"""A simulated device's own event loop, in a thread of its own that runs real-time just below
the rig's clock where the OS allows (``daq.priority.SIMULATOR_PRIORITY``).

A device answers and keeps its watchdog on a CPU of its own, whatever the host does; at
normal priority, sharing the GIL, a busy host starved a simulated PLC past the Modbus read
timeout for 0.1-0.4 s at a time (issue 35, CI's ``rig pendulum``). The simulated rig
(``simulated_rig.SimulatedRigThread``) and the tests' thruster controller run on one.
"""

from __future__ import annotations

import asyncio
import inspect
import threading
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

from daq.priority import SIMULATOR_PRIORITY, set_realtime


class DeviceLoop:
    """An asyncio loop running in a daemon thread named ``name``, started on construction;
    :meth:`submit` runs work on it, :meth:`close` ends it."""

    def __init__(self, name: str) -> None:
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        set_realtime(SIMULATOR_PRIORITY, warn=False)
        asyncio.set_event_loop(self._loop)
        self._loop.run_forever()

    @property
    def running(self) -> bool:
        """The loop is open and its thread alive."""
        return not self._loop.is_closed() and self._thread.is_alive()

    def submit(self, fn: Callable[..., Any], *args: Any) -> Future[Any]:
        """``fn(*args)`` on the device's loop (awaited there if awaitable): its future."""

        async def run() -> Any:
            result = fn(*args)
            return await result if inspect.isawaitable(result) else result

        return asyncio.run_coroutine_threadsafe(run(), self._loop)

    def close(self) -> None:
        """Stop the loop and end the thread (the loop is closed once the thread has ended)."""
        if self._loop.is_closed():
            return
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(5.0)
        if not self._thread.is_alive():
            self._loop.close()
