"""The planner's compiled prediction loop (``estimation.design.compiled_prediction``) steps
bit for bit as the NumPy loop it replaced (``_numpy_simulate`` here, the loop as it was):
runs that reach their travel, that end at the time limit, a load the friction holds, a
negative load, and a set that would reverse without the no-backwards rule."""

from __future__ import annotations

import numpy as np
import pytest

from estimation.design.information import STEP_S, _simulate


def _numpy_simulate(theta, load, extra, travel, t_end):
    """``information._simulate`` before it was compiled (40d18ee)."""
    s = np.sign(load)
    m, kl, kq, fc, b = (theta[:, i] for i in range(5))
    net_static = abs(load) - np.maximum(fc, 0.0)
    n = int(t_end / STEP_S)
    x = np.zeros(len(theta))
    v = np.zeros(len(theta))
    xs = np.empty((n, len(theta)))
    for k in range(n):
        a = (load - kl * v - kq * np.abs(v) * v - fc * s + b) / (m + extra)
        a = np.where((v == 0) & (net_static <= 0), 0.0, a)
        v = v + a * STEP_S
        v = np.where(v * s < 0, 0.0, v)
        x = x + v * STEP_S
        xs[k] = x
        if abs(x[0]) >= travel:
            xs = xs[: k + 1]
            break
    t = STEP_S * np.arange(1, len(xs) + 1)
    return xs, t, float(np.max(np.abs(np.diff(xs[:, 0])) / STEP_S, initial=0.0))


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
    sets = _sets(theta)
    xs, t, peak = _simulate(sets, load, extra, travel, t_end)
    xs_np, t_np, peak_np = _numpy_simulate(sets, load, extra, travel, t_end)
    assert xs.shape == xs_np.shape and xs.tobytes() == xs_np.tobytes()
    assert t.tobytes() == t_np.tobytes() and peak == peak_np
