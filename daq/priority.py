"""CPU priorities around the rig's process: the simulated PLC beside the clock's real-time
thread, and the helper processes the service starts.

The acquisition clock's thread runs SCHED_FIFO (:func:`set_realtime`); the in-process
simulated rig just below it (``SIMULATOR_PRIORITY``: it stands in for a PLC with its own
CPU), the thruster line's I/O thread below that (``THRUSTER_LINK_PRIORITY``) and the
session's worker threads at the bottom (``WORKER_PRIORITY``: they share the GIL). Work that
may wait (fits, reports, imports) runs in helper processes at normal scheduling and
positive niceness (:func:`lower_priority`), whatever the thread that started them ran at.

Tried and left out (issue 35): every other thread of the service SCHED_FIFO at priority 1.
Beside an estimation and two busy processes it cut the clock's p99 lateness from 4.3 to
0.8 ms, but under 50 HTTP requests per second the service's threads then took a core away
from everything else and the soak lost polls and slots (782 skipped, 255 failed in 600 s).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import threading
import weakref
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

log = logging.getLogger(__name__)

#: The OS scheduling of a thread as found: (policy, its parameter, niceness).
Scheduling = tuple[int, os.sched_param, int]

#: SCHED_FIFO priority of the simulated rig's thread (where the OS allows): below the
#: clock's (10, :func:`set_realtime`), above the process's other threads.
SIMULATOR_PRIORITY = 5

#: SCHED_FIFO priority of the thruster line's I/O thread in a real-time session: above every
#: normal thread, below the clock and the simulated devices (which stand in for hardware with
#: its own CPU; on a real rig nothing else runs real-time). The heartbeat is decided on the
#: clock's loop, but the frame goes out from this thread; at normal priority a loaded host
#: held it back 0.4 s and the controller's watchdog tripped mid-calibration (rehearsal R11 of
#: issue 35). The thread only blocks on the line (one frame and its reply per tick), so it
#: cannot take a core from anyone.
THRUSTER_LINK_PRIORITY = 4

#: SCHED_FIFO priority of a real-time session's worker threads (its loop's default executor:
#: ``asyncio.to_thread``, the store's writes and the rig lock's calls): the lowest, below
#: everything that keeps time. They share the GIL with the real-time threads, so whatever
#: priority they run at, the clock, the simulated rig and the thruster line wait at when one
#: holds it. At normal priority, beside two busy loops, a worker was preempted holding the
#: GIL (or the lock of its condition variable) and waited 0.4-1.7 s for a CPU while the
#: clock's thread slept in the GIL's futex: no heartbeat for 0.4-1.8 s, the controller's
#: watchdog tripped mid-calibration (traced with ``perf sched`` and per-thread schedstat;
#: issue 34). Their work is short (a batch of samples, a lock file): real-time at the bottom,
#: they run it at once instead of making every real-time thread wait for a CPU.
WORKER_PRIORITY = 1


def lower_priority(niceness: int) -> None:
    """In a helper process (fits, reports, imports): normal scheduling at ``niceness``,
    whatever it inherited from the thread that started it (real-time, or negative)."""
    with contextlib.suppress(OSError):
        if os.sched_getscheduler(0) != os.SCHED_OTHER:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        os.setpriority(os.PRIO_PROCESS, 0, niceness)


def set_realtime(priority: int = 10, *, warn: bool = True) -> bool:
    """Schedule the calling thread SCHED_FIFO at ``priority`` (1-99), else at niceness -10.

    On a busy machine a normal-priority clock wakes up to a few ms late (the
    scheduler runs someone else first). A real-time thread preempts normal work at
    once; the clock only spins ``spin_s`` per tick, so it cannot starve the machine.
    Only the calling thread runs real-time: the policy is set with
    ``SCHED_RESET_ON_FORK``, so threads it starts later (the event loop's worker threads,
    the thruster link's) and child processes start at normal priority (checked in
    ``tests/daq/test_collector.py``). The niceness fallback is inherited by threads it starts.
    Needs CAP_SYS_NICE (or root); returns False when refused, with a warning if ``warn``
    (a command-line run on a laptop asks quietly: it runs fine at normal priority).
    """
    if not 1 <= priority <= 99:
        raise ValueError(f"priority must be within 1..99, got {priority!r}")
    try:
        policy = os.SCHED_FIFO | getattr(os, "SCHED_RESET_ON_FORK", 0)
        os.sched_setscheduler(0, policy, os.sched_param(priority))
        return True
    except (OSError, AttributeError) as err:
        first = err
    try:
        os.setpriority(os.PRIO_PROCESS, 0, -10)
    except OSError as err:
        if warn:
            log.warning("acquisition clock stays at normal priority: %s; %s", first, err)
        return False
    if warn:
        log.warning("acquisition clock: no SCHED_FIFO (%s); running at niceness -10", first)
    return True


def thruster_link_realtime() -> bool:
    """In the thruster line's I/O thread of a real-time session (``io_thread_setup`` of
    ``thrusters.driver.ThrusterDriver.open``): SCHED_FIFO at ``THRUSTER_LINK_PRIORITY``,
    quietly normal where the OS refuses; whether it was granted."""
    return set_realtime(THRUSTER_LINK_PRIORITY, warn=False)


def scheduling() -> Scheduling:
    """The calling thread's scheduling, to give back with :func:`restore_scheduling`."""
    return os.sched_getscheduler(0), os.sched_getparam(0), os.getpriority(os.PRIO_PROCESS, 0)


def restore_scheduling(saved: Scheduling) -> None:
    """Give the calling thread back the scheduling :func:`scheduling` found."""
    policy, param, niceness = saved
    with contextlib.suppress(OSError):
        os.sched_setscheduler(0, policy, param)
        os.setpriority(os.PRIO_PROCESS, 0, niceness)


class WorkerThreads(ThreadPoolExecutor):
    """An event loop's default executor whose threads run each task at ``priority``:
    SCHED_FIFO at it (:func:`set_realtime`), or as they started when None. Set while a
    real-time session is open (:data:`WORKER_PRIORITY`); idle threads change at their next
    task."""

    def __init__(self) -> None:
        super().__init__(thread_name_prefix="rig-worker")
        self.priority: int | None = None
        self._local = threading.local()

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future:
        return super().submit(self._at_priority, fn, *args, **kwargs)

    def _at_priority(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Any:
        wanted, local = self.priority, self._local
        if getattr(local, "priority", None) != wanted:
            if not hasattr(local, "started"):
                local.started = scheduling()
            if wanted is None:
                restore_scheduling(local.started)
            else:
                set_realtime(wanted, warn=False)
            local.priority = wanted
        return fn(*args, **kwargs)


_workers: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, WorkerThreads] = (
    weakref.WeakKeyDictionary()
)


def worker_threads(loop: asyncio.AbstractEventLoop) -> WorkerThreads:
    """``loop``'s default executor as :class:`WorkerThreads` (installed on first call)."""
    workers = _workers.get(loop)
    if workers is None:
        workers = _workers[loop] = WorkerThreads()
        loop.set_default_executor(workers)
    return workers
