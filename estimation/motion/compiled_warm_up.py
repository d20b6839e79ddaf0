"""The compiled RK4 loop (``compiled.py``) made ready before the first estimate a user asks for.

numba compiles ``compiled.integrate_grid`` on its first call in a process and keeps the
machine code in its cache (``cache=True``: ``__pycache__`` beside the source, else
``$NUMBA_CACHE_DIR`` or the user's cache folder). On a fresh install, or after
``compiled.py`` changed, that first call costs 5–17 s of CPU (14–17 s with the planner's
loop on a 2-core machine, ``bench/estimate_process.py``); from a warm cache it loads in
~0.5 s. :func:`warm_up` makes that first call on a problem of one state and three steps,
through ``kernel.step_grid`` and ``kernel.hermite`` (the grid's read-off), so with exactly
the argument types an estimate passes (numba compiles one machine-code version per type
signature, and every estimate's signature is the same), and the test planner's compiled
prediction loop (``estimation.design.compiled_prediction``, through
``information.compiled_run``). ``rig warm-up`` runs it; ``rig serve`` runs it in a
background process at its start.
"""

from __future__ import annotations

import time

import numpy as np

from estimation.design.information import compiled_run
from estimation.motion.kernel import hermite, step_grid
from estimation.motion.terms import LIBRARY, TermValues

#: A smooth term and a set-valued one: the loop's branches all take the same signature.
_TERMS = ("linear_damping", "quadratic_damping", "coulomb_friction")


def warm_up() -> float:
    """Compile the RK4 loop, or load it from numba's cache; returns the CPU seconds spent."""
    start = time.process_time()
    one = np.ones((1, 1))
    forces = [TermValues(LIBRARY[name], one) for name in _TERMS]
    grid = step_grid(np.zeros((1, 1)), one, np.ones((1, 1, 1)), one, forces, 0.01, 3, np.ones(1), 1)
    if grid is None:
        raise RuntimeError(f"warm-up: a term of {_TERMS} has no compiled form")
    hermite(grid[0][:, :, 0], grid[1][:, :, 0], 0.01, np.array([[0.0, 0.015]]))
    compiled_run(np.array([[1.0, 1.0, 1.0, 0.0, 0.0]]), 1.0, 0.0, 1.0, 3)
    return time.process_time() - start


if __name__ == "__main__":  # ``rig serve`` starts this at its start, at the lowest priority
    import os

    os.nice(19)  # never before the rig's clock, the service or a user's estimate
    warm_up()
