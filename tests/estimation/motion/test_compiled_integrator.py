"""The compiled RK4 loop (``estimation.motion.compiled``) steps exactly as the NumPy loop it
replaces: every library force term has a compiled form read off its own regressor, and the
two loops give the same trajectories (to rounding) alone, with dry friction stepped either
way, and for a diverging trial; a term without a form still integrates (in NumPy), and so do
a process's first short grids."""

from __future__ import annotations

import sys
from dataclasses import replace

import numpy as np
import pytest

from estimation.axis.model import simulate
from estimation.axis.prepared_run import prepare
from estimation.motion import equation, kernel
from estimation.motion.equation import Track, integrate
from estimation.motion.kernel import V_BASIS, X_BASIS, form_of
from estimation.motion.terms import LIBRARY, Term, TermValues
from tests.estimation.term_cases import tow_set

FORCE_TERMS = [name for name, t in LIBRARY.items() if t.role == "force"]
#: Same arithmetic in the same order; pow and sin may round differently by an ulp, which
#: RK4 carries along but does not grow over a record.
ROUNDING = 1e-12


@pytest.fixture(autouse=True)
def compiled_from_the_first_grid(monkeypatch):
    """``integrate`` runs the compiled loop (its NumPy budget spent: ``kernel.LOOP``)."""
    monkeypatch.setattr(equation, "LOOP", replace(kernel.LOOP, numpy_steps=kernel.NUMPY_STEPS))


@pytest.mark.parametrize("name", FORCE_TERMS)
def test_every_force_term_has_a_compiled_form_equal_to_its_regressor(name):
    term = LIBRARY[name]
    form = form_of(term)
    assert form is not None, f"{name}: no compiled form (it would integrate in NumPy)"
    rng = np.random.default_rng(1)
    x, v = rng.normal(0, 2, 200), rng.normal(0, 2, 200)
    v[:10] = 0.0
    compiled = form.scale * X_BASIS[form.x_code](x) * V_BASIS[form.v_code](v)
    np.testing.assert_allclose(compiled, term.phi(x, v), rtol=1e-14, atol=1e-300)


def test_a_regressor_outside_the_basis_has_no_form():
    smooth_sign = Term("tanh_friction", "f = −F·tanh(ẋ/0.1)", ("N", "N·m"), "", "")
    smooth_sign = replace(smooth_sign, phi=lambda x, v: -np.tanh(v / 0.1))
    assert form_of(smooth_sign) is None


def _decay_tracks():
    tau = np.arange(0.0, 6.0, 0.05)
    drive = 3.0 * np.sin(2.0 * tau)
    return [Track(tau, None, 2.0, 1.0, 0.3), Track(tau, drive, 2.0, 1.0, 0.3)]


def _integrate_both(monkeypatch, coefficients, x0, v0, h=0.02, inertia=None):
    tracks = _decay_tracks()
    sets = x0.shape[0]
    inertia = np.full((sets, 1), 3.0) if inertia is None else inertia
    compiled = integrate(tracks, inertia, coefficients, x0, v0, h)
    with monkeypatch.context() as m:
        m.setattr(kernel, "forms_of", lambda terms: None)
        numpy = integrate(tracks, inertia, coefficients, x0, v0, h)
    return compiled, numpy


def _assert_same(a, b):
    for (xa, va), (xb, vb) in zip(a, b, strict=True):
        scale = max(float(np.ptp(xb)), 1e-12)
        np.testing.assert_allclose(xa, xb, rtol=0, atol=ROUNDING * scale)
        np.testing.assert_allclose(va, vb, rtol=0, atol=ROUNDING * max(float(np.ptp(vb)), 1e-12))


def _sets(values):
    return np.asarray(values, dtype=float)[:, None]


@pytest.mark.parametrize("name", FORCE_TERMS)
def test_the_compiled_loop_steps_each_term_as_numpy_does(monkeypatch, name):
    """Each term beside a spring and linear damping, on a free and a driven record, for
    three parameter sets (one with the term off): the same trajectories."""
    sets = _sets([0.0, 0.7, 2.5])
    coefficients = [
        TermValues(LIBRARY["restoring_spring"], _sets([40.0, 40.0, 40.0])),
        TermValues(LIBRARY["linear_damping"], _sets([0.4, 0.4, 0.4])),
        TermValues(LIBRARY[name], sets),
    ]
    x0 = np.array([[0.2, 0.0], [0.2, 0.0], [-0.1, 0.05]])
    v0 = np.array([[0.0, 0.0], [0.3, 0.0], [0.0, -0.2]])
    compiled, numpy = _integrate_both(monkeypatch, coefficients, x0, v0)
    _assert_same(compiled, numpy)
    assert np.ptp(compiled[0][0][1]) > 0.05  # the record moved


def test_a_diverging_trial_is_frozen_alike(monkeypatch):
    """A negative damping far beyond the data (a trial step): both loops freeze it at the
    divergence limit (1e3 × the record's range) alike, and it stays finite."""
    coefficients = [
        TermValues(LIBRARY["restoring_spring"], _sets([40.0, 40.0])),
        TermValues(LIBRARY["linear_damping"], _sets([0.4, -300.0])),
    ]
    x0, v0 = np.full((2, 2), 0.2), np.zeros((2, 2))
    compiled, numpy = _integrate_both(monkeypatch, coefficients, x0, v0)
    _assert_same(compiled, numpy)
    assert all(np.all(np.isfinite(x)) for x, _ in compiled)
    assert np.max(np.abs(compiled[0][0][1])) >= 1e3 * 0.3  # it did diverge


@pytest.mark.parametrize("effects", [(), ("coulomb_friction",), ("cubic_drag", "constant_bias")])
def test_the_axis_simulator_steps_as_numpy_does(monkeypatch, effects):
    """Tows by RK4 with dry friction held in the acceleration (a restoring spring keeps them
    off the closed form), forward and reverse, four parameter sets."""
    prepared = [prepare(r) for r in tow_set("10kg", 0, reverse=True)]
    base = [10.0, 2.0, 15.0, 0.3]
    values = {"coulomb_friction": 0.1, "cubic_drag": 7.0, "constant_bias": 0.05}
    row = [*base, *(values[e] for e in effects)]
    theta = np.array([row, [v * 1.01 for v in row], [v * 0.5 for v in row], row])
    theta[3, 3] = 0.0
    names = ("restoring_spring", *effects)
    compiled = simulate(theta, names, prepared)
    with monkeypatch.context() as m:
        m.setattr(kernel, "forms_of", lambda terms: None)
        numpy = simulate(theta, names, prepared)
    _assert_same(compiled, numpy)


def test_a_process_steps_its_first_short_grids_in_numpy_then_compiled(monkeypatch):
    """Before numba is loaded, grids of at most NUMPY_GRID_STEPS steps run in NumPy until
    NUMPY_STEPS in all, a longer grid compiled from the first; the same trajectories."""
    choice = replace(kernel.LOOP, numpy_steps=0)
    monkeypatch.setattr(equation, "LOOP", choice)
    monkeypatch.delitem(sys.modules, kernel.COMPILED, raising=False)  # not loaded yet
    ran: list[int] = []

    def counted(*args):
        ran.append(args[6])  # n_steps
        return kernel.step_grid(*args)

    monkeypatch.setattr(equation, "step_grid", counted)
    coefficients = [
        TermValues(LIBRARY["restoring_spring"], _sets([40.0])),
        TermValues(LIBRARY["quadratic_damping"], _sets([0.4])),
    ]
    x0, v0 = np.array([[0.2, 0.0]]), np.array([[0.0, 0.1]])
    tracks = _decay_tracks()
    paths = [integrate(tracks, np.full((1, 1), 3.0), coefficients, x0, v0, 0.02)]
    steps = choice.numpy_steps
    assert ran == [] and 0 < steps <= kernel.NUMPY_GRID_STEPS
    while not ran:
        paths.append(integrate(tracks, np.full((1, 1), 3.0), coefficients, x0, v0, 0.02))
    assert len(paths) == kernel.NUMPY_STEPS // steps + 1  # the grid over the budget: compiled
    assert choice.numpy_steps == steps * (len(paths) - 1) <= kernel.NUMPY_STEPS
    for path in paths[1:]:
        _assert_same(path, paths[0])

    ran.clear()
    fresh = replace(kernel.LOOP, numpy_steps=0)
    monkeypatch.setattr(equation, "LOOP", fresh)
    integrate(tracks, np.full((1, 1), 3.0), coefficients, x0, v0, 0.005)
    assert ran and ran[0] > kernel.NUMPY_GRID_STEPS and fresh.numpy_steps == 0


@pytest.mark.parametrize("seed", range(6))
def test_the_compiled_read_off_of_a_grid_gives_the_same_numbers_as_numpys(seed):
    """``kernel.hermite`` (a compiled grid's samples) is ``equation.hermite`` bit for bit:
    one time row for every set or one per set, samples on grid points, between them, before
    the first (held) and past the last step."""
    rng = np.random.default_rng(seed)
    steps, sets, n, h = 40 + 30 * seed, 1 + 5 * seed, 25 + 40 * seed, 0.01 + 0.03 * seed
    grid_x, grid_v = rng.normal(size=(steps, sets)), 10 * rng.normal(size=(steps, sets))
    tau = np.sort(rng.uniform(-2 * h, (steps + 1) * h, size=(1 if seed % 2 else sets, n)))
    tau[:, : n // 3] = np.round(tau[:, : n // 3] / h) * h
    tau = np.maximum(tau, 0.0)
    numpy_x, numpy_v = equation.hermite(grid_x, grid_v, h, tau)
    compiled_x, compiled_v = kernel.hermite(grid_x, grid_v, h, tau)
    assert compiled_x.shape == numpy_x.shape == (sets, n)
    assert np.array_equal(compiled_x, numpy_x) and np.array_equal(compiled_v, numpy_v)
