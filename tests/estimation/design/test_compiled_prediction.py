"""The planner's compiled prediction loop (``estimation.design.compiled_prediction``) steps
bit for bit as its NumPy loop (``information.numpy_run``): runs that reach their travel, that
end at the time limit, a load the friction holds, a negative load, and a set that would
reverse without the no-backwards rule; and a process steps in NumPy only until numba is
loaded or it has taken ``NUMPY_STEPS`` there."""

from __future__ import annotations

import numpy as np
import pytest

from estimation.design import information
from estimation.design.information import STEP_S, compiled_run, numpy_run
from estimation.loop_choice import LoopChoice


def _sets(theta):
    """The model and a relative 1e-4 central difference on each parameter (as ``predict``)."""
    theta = np.asarray(theta, dtype=float)
    sets = [theta]
    for i in range(theta.size):
        for sign in (1.0, -1.0):
            d = theta.copy()
            d[i] += sign * 1e-4 * max(abs(theta[i]), 1e-3)
            sets.append(d)
    return np.array(sets)


@pytest.mark.parametrize(
    ("theta", "load", "extra", "travel", "t_end"),
    [
        ((143.0, 20.0, 35.0, 0.0, 0.0), 24.5, 2.5, 5.3, 120.0),  # reaches its travel
        ((143.0, 20.0, 35.0, 3.0, 0.4), -83.3, 8.5, 5.5, 120.0),  # negative, with friction
        ((143.0, 20.0, 35.0, 0.0, 0.0), 24.5, 0.0, 50.0, 7.3),  # ends at the time limit
        ((143.0, 20.0, 35.0, 30.0, 0.0), 24.5, 0.0, 5.3, 2.0),  # the friction holds it
        ((143.0, 20.0, 35.0, 24.5, 0.0), 24.5, 0.0, 5.3, 2.0),  # exactly at the friction
        ((2.0, 0.5, 0.3, 0.0, -3.0), 0.2, 0.0, 5.3, 3.0),  # pushed back: never reverses
    ],
)
def test_the_compiled_prediction_is_the_numpy_loop_bit_for_bit(theta, load, extra, travel, t_end):
    sets, n = _sets(theta), int(t_end / STEP_S)
    compiled = compiled_run(sets, load, extra, travel, n)
    stepped = numpy_run(sets, load, extra, travel, n)
    assert compiled.shape == stepped.shape and compiled.tobytes() == stepped.tobytes()


def test_a_process_steps_in_numpy_until_numba_is_loaded_or_its_budget_is_spent(monkeypatch):
    import sys

    sets = _sets((143.0, 20.0, 35.0, 0.0, 0.0))
    monkeypatch.delitem(sys.modules, "numba", raising=False)
    used = []
    monkeypatch.setattr(information, "numpy_run", lambda *a: used.append("numpy") or numpy_run(*a))
    # (the compiled stand-in steps in NumPy: numba is not to be imported while it is hidden)
    monkeypatch.setattr(
        information, "compiled_run", lambda *a: used.append("compiled") or numpy_run(*a)
    )
    monkeypatch.setattr(information, "LOOP", LoopChoice("numba", 300))
    xs, _, _ = information._simulate(sets, 24.5, 0.0, 5.3, 2.0)  # 200 steps
    assert used == ["numpy"] and information.LOOP.numpy_steps == len(xs) == 200
    information._simulate(sets, 24.5, 0.0, 5.3, 2.0)  # 400 steps, over the budget
    information._simulate(sets, 24.5, 0.0, 5.3, 2.0)
    assert used == ["numpy", "numpy", "compiled"]
    monkeypatch.setattr(information, "LOOP", LoopChoice("numba", information.NUMPY_STEPS))
    monkeypatch.setitem(sys.modules, "numba", object())  # an estimate loaded it: compiled
    information._simulate(sets, 24.5, 0.0, 5.3, 2.0)
    assert used[-1] == "compiled"
