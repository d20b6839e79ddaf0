"""Keeping CPython's full garbage collections off the rig's path.

A full (generation 2) collection walks every tracked object while holding the GIL: 0.07 s
in an idle process, 0.15-0.3 s in a loaded one (issue 19), the size of a missed thruster
heartbeat (the controller's watchdog trips at 0.4 s). Two measures, for every process that
drives a rig (``rig serve`` and the test commands such as ``rig tow``):

* :func:`freeze_after_startup`: once the rig is open, everything loaded so far (modules,
  the session, the simulator) moves to the permanent generation, which no collection
  walks; a full collection then only sees what was made since.
* :func:`hold_full_collections` while the thrusters are armed and while a run records: the
  generation-2 threshold is raised out of reach (young collections, ~1 ms, go on, so
  short-lived cycles are still freed); when the last reason ends (disarmed, the run
  stored) the threshold returns and full collections resume at their usual rhythm. Cyclic
  garbage that survives two young collections waits until then. A run with no thrust
  needs it too: a full collection started by a normal-priority thread (an HTTP request)
  holds the GIL while the loaded host preempts that thread, and the real-time clock waits
  for the GIL; a tow in the rehearsal of 6a050e9 lost 4 slots (0.4 s) so.

Every ``rig`` command also loads its modules and opens its store under
:func:`no_collections_while_loading` (start-up CPU, not pauses: issue 33).

``bench/gc_pause.py`` measures the longest pause of a driving process under load with
and without these measures.
"""

from __future__ import annotations

import gc
import logging
import threading
from collections.abc import Iterator
from contextlib import contextmanager

log = logging.getLogger(__name__)

#: The generation-2 threshold while held: full collections are never due (C int max).
HELD_THRESHOLD = 2**31 - 1

#: Why full collections are held (e.g. "thrusters armed", "run <id> recording").
ARMED = "thrusters armed"

_lock = threading.Lock()
_saved: tuple[int, int, int] | None = None
_reasons: set[str] = set()


@contextmanager
def no_collections_while_loading() -> Iterator[None]:
    """No collection while a command loads its modules or opens the store, and what they
    made frozen after (``gc.freeze``): it lives to the end of the process, so walking it,
    then and in every later full collection, is waste (~0.1 s of ``rig runs``'s CPU, a
    full collection ~0.04 s of it; issue 33). The collector is on again afterwards if it
    was before."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if was_enabled:
            gc.enable()


def freeze_after_startup() -> None:
    """Move every object alive now to the permanent generation (``gc.freeze``): call once
    the rig is open, before the first test; later collections never walk them."""
    gc.freeze()
    log.debug("gc: %d objects frozen after start-up", gc.get_freeze_count())


def hold_full_collections(held: bool, reason: str = ARMED) -> None:
    """``True``: no full collection until ``reason`` is released (thrusters armed, a run
    recording); ``False``: release ``reason``, and once no reason is left the thresholds
    are as they were before. Idempotent both ways."""
    global _saved
    with _lock:
        if held:
            _reasons.add(reason)
        else:
            _reasons.discard(reason)
        if _reasons and _saved is None:
            _saved = gc.get_threshold()
            gc.set_threshold(_saved[0], _saved[1], HELD_THRESHOLD)
        elif not _reasons and _saved is not None:
            gc.set_threshold(*_saved)
            _saved = None


def release_all_full_collections() -> None:
    """Drop every reason at once (the session closes): the thresholds as they were."""
    with _lock:
        reasons = list(_reasons)
    for reason in reasons:
        hold_full_collections(False, reason)


def full_collections_held() -> bool:
    """Whether :func:`hold_full_collections` holds them now."""
    return _saved is not None
