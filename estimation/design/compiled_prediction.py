"""The planner's run prediction (``information.numpy_run``) compiled (numba): the same
semi-implicit Euler arithmetic, in the same order, one parameter set after another.

A prediction steps 11 parameter sets (the model and its central differences) every 10 ms
until the body reaches its travel, up to 12,000 steps; in NumPy each step was ~15 array
operations on arrays of 11 numbers, and their dispatch was the whole cost (a ``choose`` of
the planner: ~1 s of CPU, 17 predictions of ~2,000 steps; 260 predictions of
``tests/estimation/design`` took 14.7 s). Compiled, they take 0.04 s, the same bits
(``tests/estimation/design/test_compiled_prediction.py`` against the NumPy loop).

numba is imported with this module, which ``information.compiled_run`` loads when the
process has numba loaded already or has stepped ``information.NUMPY_STEPS`` in NumPy
(``information.LOOP``, an ``estimation.loop_choice.LoopChoice``: loading numba costs ~0.6 s of CPU).
The machine code is cached beside the source (``cache=True``) and compiled by
``estimation.motion.compiled_warm_up`` (``rig warm-up``), as the estimator's RK4 loop is.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def run_from_rest(m, kl, kq, fc, b, stuck, load, direction, extra, step, travel, n):
    """Positions (n', S) of the S sets (m, K_L, K_Q, F_c, b; ``stuck``: the friction holds
    the load) from rest under ``load`` (``direction`` its sign, ``extra`` the hung weight's
    inertia), every ``step`` for ``n`` steps or until set 0 reaches ``travel`` (n' ≤ n):

        (m + extra)·v̇ = load − K_L·v − K_Q·|v|·v − F_c·direction + b

    v never reverses (friction does not drive the body backwards); a stuck set at rest stays."""
    sets = m.size
    xs = np.empty((n, sets))
    x = np.zeros(sets)
    v = np.zeros(sets)
    for k in range(n):
        for j in range(sets):
            vj = v[j]
            a = (load - kl[j] * vj - kq[j] * abs(vj) * vj - fc[j] * direction + b[j]) / (
                m[j] + extra
            )
            if vj == 0 and stuck[j]:
                a = 0.0
            vj = vj + a * step
            if vj * direction < 0:
                vj = 0.0
            v[j] = vj
            x[j] = x[j] + vj * step
            xs[k, j] = x[j]
        if abs(x[0]) >= travel:
            return xs[: k + 1]
    return xs
