"""CPU priorities around the rig's process: the simulated PLC beside the clock's real-time
thread, and the helper processes the service starts.

The acquisition clock's thread runs SCHED_FIFO (``daq.acquisition.set_realtime``); the
in-process simulated rig runs just below it (``SIMULATOR_PRIORITY``: it stands in for a PLC
with its own CPU). Work that may wait (fits, reports, imports) runs in helper processes at
normal scheduling and positive niceness (:func:`lower_priority`), whatever the thread that
started them ran at.

Tried and left out (issue 35): every other thread of the service SCHED_FIFO at priority 1.
Beside an estimation and two busy processes it cut the clock's p99 lateness from 4.3 to
0.8 ms, but under 50 HTTP requests per second the service's threads then took a core away
from everything else and the soak lost polls and slots (782 skipped, 255 failed in 600 s).
"""

from __future__ import annotations

import contextlib
import os

#: SCHED_FIFO priority of the in-process simulated rig's thread in real-time mode: below the
#: clock's (10, ``daq.acquisition.set_realtime``), above the process's other threads.
SIMULATOR_PRIORITY = 5


def lower_priority(niceness: int) -> None:
    """In a helper process (fits, reports, imports): normal scheduling at ``niceness``,
    whatever it inherited from the thread that started it (real-time, or negative)."""
    with contextlib.suppress(OSError):
        if os.sched_getscheduler(0) != os.SCHED_OTHER:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        os.setpriority(os.PRIO_PROCESS, 0, niceness)
