"""One fit for records that start free and records at rest until their release (issue 31:
one engine): a free heave decay and a constant pull from rest of the same body, fitted
alone and together by ``fit_motion``, give one added mass and one damping law.

The records come from scipy's solve_ivp (never our integrator), at 10, 143 and 1000 kg:
(M + A)·ẍ = F − B₁ẋ − B₂|ẋ|ẋ − k·x with A = 0.8 M, k = 40 M (N/m), B₁ at 3 % of critical,
B₂ = 4 M; the decay from 0.05 m, the pull at F = 0.7·k·0.05 released at 1 s; 20 µm noise;
both about an equilibrium 0.3 m away from the encoder's zero.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from estimation.motion.output_error_fit import fit_motion
from estimation.motion.records import Record, Setup

EQUILIBRIUM = 0.3  # m
NOISE = 2e-5  # m


def _body(mass: float) -> dict[str, float]:
    k = 40.0 * mass
    total = 1.8 * mass
    return dict(mass=mass, added=0.8 * mass, k=k, b1=0.03 * 2 * np.sqrt(total * k), b2=4.0 * mass)


def _record(body: dict[str, float], x0: float, force: float, release: float, seed: int):
    """Samples at 20 Hz over 15 s: at x0 until ``release``, then the motion."""
    total = body["mass"] + body["added"]

    def rhs(_: float, y: np.ndarray) -> list[float]:
        v = y[1]
        f = force - body["b1"] * v - body["b2"] * abs(v) * v - body["k"] * y[0]
        return [v, f / total]

    t = np.arange(0.0, 15.0, 0.05)
    x = np.full(t.size, x0)
    moving = t > release
    sol = solve_ivp(rhs, (release, t[-1]), [x0, 0.0], t_eval=t[moving], rtol=1e-10, atol=1e-12)
    x[moving] = sol.y[0]
    noise = NOISE * np.random.default_rng(seed).standard_normal(t.size)
    return t, x + EQUILIBRIUM + noise


@pytest.mark.parametrize("mass", [10.0, 143.0, 1000.0])
def test_a_decay_and_a_pull_from_rest_give_one_answer_alone_and_together(mass):
    body = _body(mass)
    t1, x1 = _record(body, 0.05, 0.0, 0.0, seed=1)  # released at its first sample
    force = 0.7 * body["k"] * 0.05
    t2, x2 = _record(body, 0.0, force, 1.0, seed=2)
    decay = Record("decay", t1, x1)
    pull = Record("pull", t2, x2, force, released_at=1.0)
    setup = Setup(
        "heave",
        known_inertia=body["mass"],
        known_terms={"restoring_spring": body["k"]},
        terms=("linear_damping", "quadratic_damping"),
    )
    truth = {
        "inertia": body["added"],
        "linear_damping": body["b1"],
        "quadratic_damping": body["b2"],
    }
    fits = {
        "decay": fit_motion([decay], setup),
        "pull": fit_motion([pull], setup),
        "both": fit_motion([decay, pull], setup),
    }
    for label, fit in fits.items():
        for name, value in truth.items():
            # 3σ: one seed per case; a biased start kind (the pull's rest, the decay's
            # state) would sit tens of σ off
            assert abs(fit.value(name) - value) <= 3 * fit.sigma(name), (label, name, fit.values)
        assert fit.value("inertia") == pytest.approx(body["added"], rel=0.01), label
        assert fit.rmse == pytest.approx(NOISE, rel=0.15), label
    both = fits["both"]
    assert list(both.free) == [True, False]
    assert np.allclose(both.equilibrium, EQUILIBRIUM, atol=10 * NOISE)
    assert np.all(both.initial[1] == 0.0)  # the pull starts at rest: no state fitted
    assert both.initial[0, 0] == pytest.approx(0.05, abs=10 * NOISE)
    # both records inform the one coefficient: no larger σ than the better record alone
    best_alone = min(fits["decay"].sigma("inertia"), fits["pull"].sigma("inertia"))
    assert both.sigma("inertia") <= 1.05 * best_alone
