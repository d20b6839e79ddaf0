"""Keeping CPython's full garbage collections off the rig's path.

A full (generation 2) collection walks every tracked object while holding the GIL: 0.07 s
in an idle process, 0.15-0.3 s in a loaded one (issue 19), the size of a missed thruster
heartbeat (the controller's watchdog trips at 0.4 s). Two measures, for every process that
drives a rig (``rig serve`` and the test commands such as ``rig tow``):

* :func:`freeze_after_startup`: once the rig is open, everything loaded so far (modules,
  the session, the simulator) moves to the permanent generation, which no collection
  walks; a full collection then only sees what was made since.
* :func:`hold_full_collections` while the thrusters are armed: the generation-2 threshold
  is raised out of reach (young collections, ~1 ms, go on, so short-lived cycles are still
  freed); disarming restores the threshold and full collections resume at their usual
  rhythm. Cyclic garbage that survives two young collections waits until then.

``bench/gc_pause.py`` measures the longest pause of a driving process under load with
and without these measures.
"""

from __future__ import annotations

import gc
import logging
import threading

log = logging.getLogger(__name__)

#: The generation-2 threshold while held: full collections are never due (C int max).
HELD_THRESHOLD = 2**31 - 1

_lock = threading.Lock()
_saved: tuple[int, int, int] | None = None


def freeze_after_startup() -> None:
    """Move every object alive now to the permanent generation (``gc.freeze``): call once
    the rig is open, before the first test; later collections never walk them."""
    gc.freeze()
    log.debug("gc: %d objects frozen after start-up", gc.get_freeze_count())


def hold_full_collections(held: bool) -> None:
    """``True``: no full collection until released (thrusters armed); ``False``: the
    thresholds as they were before (thrusters disarmed). Idempotent both ways."""
    global _saved
    with _lock:
        if held and _saved is None:
            _saved = gc.get_threshold()
            gc.set_threshold(_saved[0], _saved[1], HELD_THRESHOLD)
        elif not held and _saved is not None:
            gc.set_threshold(*_saved)
            _saved = None


def full_collections_held() -> bool:
    """Whether :func:`hold_full_collections` holds them now."""
    return _saved is not None
