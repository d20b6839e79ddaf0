"""Equivalent linear damping (``motion.equivalent``, ``Term.equivalent_damping``) and the
rivals rule that lets a long decay keep two damping terms (``motion.term_search``), on records
from scipy's ``solve_ivp`` (``term_cases``), never our integrator."""

from __future__ import annotations

import numpy as np
import pytest

from estimation.motion.decay_estimate import estimate_decay
from estimation.motion.terms import LIBRARY
from tests.estimation.term_cases import SCALES, decay, decay_effect

A, W = 0.0873, 2.46  # amplitude (rad) and frequency (rad/s) of the closed-form checks

#: Harmonic balance in closed form (energy per cycle of x = a·cos ωt over π·a²·ω).
CLOSED_FORM = {
    "linear_damping": 1.0,
    "quadratic_damping": 8 / (3 * np.pi) * W * A,
    "cubic_drag": 0.75 * W**2 * A**2,
    "coulomb_friction": 4 / (np.pi * W * A),
    "restoring_spring": 0.0,
    "cubic_stiffness": 0.0,
    "sine_restoring": 0.0,
    "constant_bias": 0.0,
    "equilibrium_drift": 0.0,
    "drive_inertia": 0.0,
    "release_delay": 0.0,
}


def test_every_entry_has_its_closed_form():
    assert set(CLOSED_FORM) == set(LIBRARY)


@pytest.mark.parametrize("name", list(CLOSED_FORM))
def test_equivalent_damping_per_unit_matches_the_closed_form(name):
    # the midpoint rule over 4096 phases: smooth terms exact to round-off, a step (sign ẋ)
    # to ~1e-7
    expected = CLOSED_FORM[name]
    assert LIBRARY[name].equivalent_damping(A, W) == pytest.approx(expected, rel=1e-6, abs=1e-12)


@pytest.mark.parametrize("scale", list(SCALES))
def test_a_decays_equivalent_damping_is_the_truths_over_its_swings(scale):
    """B_e(a) = B1 + 8/(3π)·ω0·a·B2 of the truth, within 2 % and 3σ at each amplitude the
    result reports, and the amplitudes span the record's swings (0.05 m down)."""
    field, b2 = decay_effect("quadratic_damping", scale)
    t, x, truth = decay(scale, seed=41, **{field: b2})
    r = estimate_decay(t, x, "heave", known_inertia=truth["known"], stiffness=truth["k"])
    omega = np.sqrt(truth["k"] / (truth["known"] + truth["added"]))
    assert r.equivalent[-1].amplitude == pytest.approx(0.05, rel=0.02)
    assert r.equivalent[0].amplitude < 0.5 * r.equivalent[-1].amplitude
    for e in r.equivalent:
        expected = truth["b1"] + 8 / (3 * np.pi) * omega * e.amplitude * b2
        assert e.value == pytest.approx(expected, rel=0.02)
        assert e.std is not None and abs(e.value - expected) <= 3 * e.std + 1e-3 * expected
        assert e.unit == "N·s/m"
    doc = r.to_json()["equivalent_linear_damping"]
    assert [d["value"] for d in doc] == [e.value for e in r.equivalent]


DAMPING = ("quadratic_damping", "coulomb_friction")


@pytest.mark.parametrize("truth_terms", [("quadratic_damping",), ("coulomb_friction",)])
def test_a_rival_is_not_added_beside_the_term_the_data_hold(truth_terms):
    """One damping term in the truth: its rival, still tried in later rounds, is not kept."""
    kw = dict(decay_effect(n, "143kg") for n in truth_terms)
    t, x, truth = decay("143kg", seed=40, **kw)
    r = estimate_decay(
        t, x, "heave", known_inertia=truth["known"], stiffness=truth["k"], candidates=DAMPING
    )
    assert r.effect_names == truth_terms
    (value,) = kw.values()
    assert r.coefficients[truth_terms[0]].value == pytest.approx(value, rel=0.02)
    # the evidence: the added step's trial whitened the residual; Q is evidence, not a rule
    (added,) = [s for s in r.steps if s.added]
    assert added.term == truth_terms[0] and added.q_after < added.q_before / 10
    forward = [s for s in r.steps if s.accepted and "backward check" not in s.reason]
    assert all(s.added == (s.term in r.effect_names) for s in forward)
