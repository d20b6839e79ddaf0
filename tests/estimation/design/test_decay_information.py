"""The next decay a decay's result names (``estimation.design.decay_information``), checked
against that decay when it is recorded: a heave decay of a 143 kg body with quadratic
damping, integrated by scipy's solve_ivp (independent of the engine's integrator), 20 Hz,
20 µm noise. The σ predicted for the quadratic damping after a second record released from
twice the first's amplitude must be what the joint fit of the two then reports, within the
spread a σ estimated from one noise draw has (±35 %; four pairs of seeds: measured 0.5–23 %
above the prediction). A record released again from the same amplitude is predicted to cut
σ by √2, as it must."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from estimation.motion.decay_estimate import estimate_decay, estimate_records
from estimation.motion.records import Record

MASS, ADDED, STIFFNESS, B1, B2 = 143.0, 114.4, 5720.0, 72.8, 572.0
KNOWN = {"known_inertia": MASS, "stiffness": STIFFNESS}


def _decay(x0: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """15 s from rest at x0 (m), 20 Hz, 20 µm of white noise."""

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        return [y[1], -(B1 * y[1] + B2 * abs(y[1]) * y[1] + STIFFNESS * y[0]) / (MASS + ADDED)]

    t = np.arange(0.0, 15.0, 0.05)
    sol = solve_ivp(rhs, (0.0, t[-1]), [x0, 0.0], t_eval=t, rtol=1e-11, atol=1e-13)
    return t, sol.y[0] + 2e-5 * np.random.default_rng(seed).standard_normal(t.size)


def test_the_next_release_named_is_the_one_that_teaches_most_and_its_sigma_comes_true():
    t, x = _decay(0.05, seed=1)
    first = estimate_decay(t, x, "heave", **KNOWN)
    assert first.effect_names == ("quadratic_damping",)
    i = first.fit_after.names.index("quadratic_damping")
    plan = {round(p.amplitude / 0.05, 1): p for p in first.next_release}
    assert sorted(plan) == [0.5, 1.0, 1.5, 2.0]
    # a quadratic damping grows with the speed: the larger the release, the more it teaches
    after = [plan[k].std_after[i] for k in (0.5, 1.0, 1.5, 2.0)]
    assert after == sorted(after, reverse=True) and after[0] < plan[0.5].std_now[i]
    (advice,) = [a for a in first.advice if a.startswith("the next decay to run")]
    assert "from 0.1 m (2× the largest release so far)" in advice
    assert "σ of quadratic_damping from" in advice
    assert first.to_json()["next_release"][3]["std_after"]["quadratic_damping"] == after[3]
    assert np.allclose(plan[1.0].std_after, plan[1.0].std_now / np.sqrt(2), rtol=0.05)

    t2, x2 = _decay(0.10, seed=2)
    both = estimate_records([Record("a", t, x), Record("b", t2, x2)], "heave", **KNOWN)
    assert both.effect_names == ("quadratic_damping",)
    measured = both.fit_after.std[both.fit_after.names.index("quadratic_damping")]
    assert 0.65 * after[3] <= measured <= 1.35 * after[3], (measured, after[3])


def test_a_linear_models_information_scales_with_the_release_squared_a_nonlinear_ones_not():
    """The next-release advice integrates one amplitude when the model is linear in the
    release (``decay_information._linear``) and scales it by A²: the same numbers as each
    amplitude's own integration, to round-off. With quadratic damping it must not scale."""
    from estimation.design import decay_information as di

    t, x = _decay(0.05, seed=1)
    for keep, linear in (((), True), (("quadratic_damping",), False)):
        result = estimate_decay(t, x, "heave", candidates=keep, **KNOWN)
        fit, planned = result.fit_after, di.planned_record(result.records[0])
        assert di._linear(planned, result.setup, fit.names) is linear
        amplitudes = [0.025, 0.05, 0.1]
        each = [di._information(planned, result.setup, fit, [a])[0] for a in amplitudes]
        together = di._information(planned, result.setup, fit, amplitudes)
        for a, b in zip(each, together, strict=True):
            assert np.allclose(a, b, rtol=1e-9, atol=0.0)
        if not linear:  # a quadratic damping's information grows faster than A²
            assert not np.allclose(together[2], together[0] * 16, rtol=1e-3)
