"""CPU priorities around the rig's process: the simulated PLC beside the clock's real-time
thread, and the helper processes the service starts.

The acquisition clock's thread runs SCHED_FIFO (:func:`set_realtime`); the in-process
simulated rig just below it (``SIMULATOR_PRIORITY``: it stands in for a PLC with its own
CPU), and the thruster line's I/O thread below that (``THRUSTER_LINK_PRIORITY``). Work that
may wait (fits, reports, imports) runs in helper processes at normal scheduling and
positive niceness (:func:`lower_priority`), whatever the thread that started them ran at.

Tried and left out (issue 35): every other thread of the service SCHED_FIFO at priority 1.
Beside an estimation and two busy processes it cut the clock's p99 lateness from 4.3 to
0.8 ms, but under 50 HTTP requests per second the service's threads then took a core away
from everything else and the soak lost polls and slots (782 skipped, 255 failed in 600 s).
"""

from __future__ import annotations

import contextlib
import logging
import os

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


def scheduling() -> Scheduling:
    """The calling thread's scheduling, to give back with :func:`restore_scheduling`."""
    return os.sched_getscheduler(0), os.sched_getparam(0), os.getpriority(os.PRIO_PROCESS, 0)


def restore_scheduling(saved: Scheduling) -> None:
    """Give the calling thread back the scheduling :func:`scheduling` found."""
    policy, param, niceness = saved
    with contextlib.suppress(OSError):
        os.sched_setscheduler(0, policy, param)
        os.setpriority(os.PRIO_PROCESS, 0, niceness)
