"""Axis model: the closed form and the RK4 integrator agree; limits behave."""

import numpy as np
import pytest

from estimation.axis.model import simulate
from estimation.axis.prepared_run import prepare
from estimation.data.run_arrays import RunData
from estimation.motion.constant_pull import constant_force_response


def _runs(drives):
    t = np.arange(0.0, 20.0, 0.1)
    return [
        prepare(
            RunData(
                f"r{i}",
                "surge",
                t,
                np.zeros_like(t),
                f,
                hung_mass_kg=abs(f) / 9.8,
                drive_inertia=0.2,
                t_release=1.0,
            )
        )
        for i, f in enumerate(drives)
    ]


def test_closed_form_matches_integration_both_directions():
    runs = _runs([4.9, -44.1, 83.3])
    theta = np.array([[143.26, 20.16, 241.14, 0.0]])
    closed = simulate(theta[:, :3], (), runs)
    # cubic_drag = 0 forces the RK4 path with the same physics
    integrated = simulate(theta, ("cubic_drag",), runs)
    for (xc, vc), (xi, vi) in zip(closed, integrated, strict=True):
        assert np.max(np.abs(xc - xi)) < 1e-6
        assert np.max(np.abs(vc - vi)) < 1e-6
    assert closed[1][0][0, -1] < 0  # a negative force moves the vehicle backwards


def test_linear_limit_of_closed_form():
    tau = np.linspace(0, 10, 101)
    x, v = constant_force_response(
        tau, np.array([[100.0]]), np.array([[20.0]]), np.array([[1e-14]]), np.array([[10.0]])
    )
    lam = 20.0 / 100.0
    expected = 0.5 * (tau - (1 - np.exp(-lam * tau)) / lam)
    assert np.allclose(x[0], expected, rtol=1e-6, atol=1e-9)
    assert v[0, -1] == pytest.approx(0.5 * (1 - np.exp(-2.0)), rel=1e-6)


def test_coulomb_friction_larger_than_force_holds_still():
    runs = _runs([4.9])
    x, _ = simulate(np.array([[143.0, 20.0, 241.0, 5.0]]), ("coulomb_friction",), runs)[0]
    assert np.all(x == 0.0)
    x, _ = simulate(
        np.array([[143.0, 20.0, 241.0, 5.0, 0.0]]), ("coulomb_friction", "restoring_spring"), runs
    )[0]
    assert np.all(np.abs(x) < 1e-12)


def _driven_run():
    """A record whose drive changes every sample (a wave force): the RK4 path, one step per
    held sample or finer."""
    t = np.arange(0.0, 20.0, 0.05)
    drive = 30.0 * np.sin(2 * np.pi * 0.4 * t)
    x = np.zeros_like(t)
    return [prepare(RunData("w", "surge", t, x, drive, drive_inertia=0.2, t_release=1.0))]


def test_sets_simulated_apart_are_the_sets_simulated_together():
    """A Jacobian's perturbed sets are integrated after (and only when) its centre's residual
    is: on the step every set shares, bit for bit what one call over all of them gives, even
    where a set alone would take a coarser step (its own path would differ)."""
    runs = _driven_run()
    theta = np.array([[143.0, 20.0, 241.0], [143.0, 20.0, 241.0002], [3.0, 100.0, 500.0]])
    together = simulate(theta, (), runs)[0]
    centre = simulate(theta, (), runs, slice(0, 1))[0]
    others = simulate(theta, (), runs, slice(1, None))[0]
    for both, part, rows in ((together, centre, slice(0, 1)), (together, others, slice(1, None))):
        assert np.array_equal(both[0][rows], part[0]) and np.array_equal(both[1][rows], part[1])
    alone = simulate(theta[:1], (), runs)[0]  # the light set alone: a coarser step
    assert not np.array_equal(alone[0], centre[0])
