"""CPU priority of the process that drives the rig, beside the clock's real-time thread,
and of the helper processes it starts.

The acquisition clock's thread runs SCHED_FIFO (``daq.acquisition.set_realtime``), but it
shares the interpreter lock with the process's other threads (HTTP, the store's writer, the
job threads). A thread at normal priority that holds the lock when a busy neighbour takes
its core keeps the clock waiting until the scheduler runs it again: milliseconds on a
loaded 2-core host (issue 35: p99 4.3 ms beside two busy processes, 0.8 ms with this). So in
real-time mode every other thread of the rig's process runs SCHED_FIFO at the lowest
priority (:func:`realtime_process`), and work that may wait (fits, reports, imports) runs in
helper processes at normal scheduling and positive niceness (:func:`lower_priority`).
"""

from __future__ import annotations

import contextlib
import logging
import os
from pathlib import Path

log = logging.getLogger(__name__)

#: SCHED_FIFO priority of the in-process simulated rig's thread in real-time mode: below the
#: clock's (10, ``daq.acquisition.set_realtime``), above the process's other threads.
SIMULATOR_PRIORITY = 5
#: SCHED_FIFO priority of the rig process's other threads in real-time mode: the lowest, so
#: the clock (10) and the simulated PLC (5) preempt them, and ordinary processes do not.
RIG_THREADS_PRIORITY = 1


def realtime_process(priority: int = RIG_THREADS_PRIORITY) -> int:
    """Run every thread of this process that is not real-time yet SCHED_FIFO at
    ``priority`` (threads and processes they start later do not inherit it); the number
    changed, 0 with a warning when the OS refuses. The kernel's real-time throttling
    (``/proc/sys/kernel/sched_rt_runtime_us``) still leaves ordinary work 5 % of each core."""
    if not 1 <= priority <= 99:
        raise ValueError(f"priority: got {priority!r}, allowed: 1..99")
    # Reset on fork: the processes and threads they start run at normal priority (a fit's
    # worker, a CSV import, a benchmark's busy neighbours must never inherit real time).
    policy = os.SCHED_FIFO | getattr(os, "SCHED_RESET_ON_FORK", 0)
    changed = 0
    tasks = Path("/proc/self/task")
    for task in sorted(tasks.iterdir()) if tasks.is_dir() else []:
        tid = int(task.name)
        with contextlib.suppress(ProcessLookupError):  # a thread that just ended
            if os.sched_getscheduler(tid) != os.SCHED_OTHER:
                continue
            try:
                os.sched_setscheduler(tid, policy, os.sched_param(priority))
            except PermissionError as err:
                log.warning("the rig's threads stay at normal priority: %s", err)
                return changed
            changed += 1
    return changed


def lower_priority(niceness: int) -> None:
    """In a helper process (fits, reports, imports): normal scheduling at ``niceness``,
    whatever it inherited from the thread that started it (real-time, or negative)."""
    with contextlib.suppress(OSError):
        if os.sched_getscheduler(0) != os.SCHED_OTHER:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        os.setpriority(os.PRIO_PROCESS, 0, niceness)
