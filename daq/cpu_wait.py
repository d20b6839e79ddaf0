"""How long the OS kept a thread waiting for a CPU: runnable, but not running.

On a busy host the kernel may leave the acquisition clock's thread on a run queue for a
tenth of a second or more while other processes run (seen beside a busy loop with the test
suite's workers: a tick spent 1-3 ms of CPU and 100-180 ms waiting for a CPU). The clock
reads this wait around each tick to tell a slot the host lost from one the device or our
own code lost (``daq.acquisition``, ``ClockStats.host_stalls``).

Linux reports it per thread in ``/proc/self/task/<tid>/schedstat`` (its second field, ns).
Where the OS does not tell, the wait reads as 0: every overrun then stays the tick's own.
Time a thread spends waiting for the GIL held by another thread is not in it (it sleeps).
"""

from __future__ import annotations

import contextlib
import os
import threading


class ThreadCpuWait:
    """The cumulative CPU wait (s) of the thread that made it; ``close()`` when done.

    Made once per run of the clock and read twice a tick: a ``pread`` on a file kept open
    (about 1.5 µs of CPU a read)."""

    def __init__(self) -> None:
        self._fd: int | None = None
        with contextlib.suppress(OSError):
            path = f"/proc/self/task/{threading.get_native_id()}/schedstat"
            self._fd = os.open(path, os.O_RDONLY)

    def __call__(self) -> float:
        if self._fd is None:
            return 0.0
        try:
            return int(os.pread(self._fd, 64, 0).split()[1]) / 1e9
        except (OSError, IndexError, ValueError):
            return 0.0

    def close(self) -> None:
        fd, self._fd = self._fd, None
        if fd is not None:
            os.close(fd)


def no_cpu_wait() -> float:
    """The CPU wait of a simulated clock's thread: none (simulated time waits for nobody)."""
    return 0.0
