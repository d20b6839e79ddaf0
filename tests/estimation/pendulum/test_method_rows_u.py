"""Every pendulum seed-method row carries U = t_0.975(ν)·σ (``pendulum.methods``), and a
seed method's headline has a budget (``pendulum_estimate.seed_budget``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from api.cli.estimate import summary_lines
from estimation.pendulum.methods import SYMBOLS, UNCERTAINTY_NOTE
from estimation.pendulum.pendulum_estimate import estimate_pendulum, pendulum_budget
from estimation.stats.method_bias import DISAGREES_SIGMAS
from estimation.uncertainty.budget import coverage_factor
from tests.estimation.pendulum_synth import decay

SEED_ROWS = ("damped-fit", "log-decrement", "equation-error", "equation-error-linear")


@pytest.fixture(scope="module")
def dry():
    """Two swings with pivot friction (which the damped sinusoid and the equation-error
    regression miss: their residual is structured), damped-fit as the headline."""
    runs = [decay(dry_friction=0.05), decay(dry_friction=0.05, seed=8, run_id="p2", amplitude=0.2)]
    return estimate_pendulum(runs, method="damped-fit", search=False)


def test_every_seed_row_carries_u_on_its_own_dof(dry):
    """Keys U, k, nu beside value and std; U = k·σ with k = t_0.975(ν); ν below the samples
    where the residual is correlated. The damped sinusoid's residual with the friction it
    misses is worth 2–3 independent samples of 400 (ν 1, k 12.7): its U ≥ 2σ by far, where
    the white σ with ν = n − 5 gave k 1.97."""
    rows = [m.to_json() for m in dry.section.methods if m.method in SEED_ROWS]
    assert {r["method"] for r in rows} == set(SEED_ROWS) and len(rows) == 8
    for row in rows:
        assert row["uncertainty"] == UNCERTAINTY_NOTE
        for name in ("added_mass", "linear_damping", "total_inertia", "total_damping"):
            c = row[name]
            assert {"value", "std", "unit", "U", "k", "nu"} <= set(c), (row["method"], name)
            assert math.isfinite(c["U"]) and c["k"] == pytest.approx(coverage_factor(c["nu"]))
            assert c["U"] == pytest.approx(c["k"] * c["std"])
        if row["method"] in ("damped-fit", "log-decrement"):
            assert row["added_mass"]["U"] >= 2 * row["added_mass"]["std"], row
    fits = [r for r in rows if r["method"] == "damped-fit"]
    assert all(r["added_mass"]["nu"] < 20 for r in fits), [r["note"] for r in fits]
    (oe, *_) = [m.to_json() for m in dry.section.methods if m.method == "output-error"]
    assert "U" not in oe["added_mass"] and oe["uncertainty"] is None  # the budget's U


def test_a_seed_headline_has_a_budget_and_the_cli_shows_each_rows_u(dry):
    """The headline α, β of damped-fit are its runs' inverse-variance mean: u_c is the
    pooled σ, ν_eff by Welch–Satterthwaite over the runs' ν, U = k·u_c; the CLI's method
    lines print each seed row's U."""
    budget = pendulum_budget(dry).to_json()
    assert budget["type_b_declared"] is False and budget["notes"]
    for name in ("added_mass", "linear_damping"):
        b = budget["coefficients"][name]
        assert b["combined_standard_uncertainty"] == pytest.approx(dry.coefficients[name].std)
        assert b["expanded_uncertainty"] == pytest.approx(
            b["coverage_factor"] * b["combined_standard_uncertainty"]
        )
        assert len(b["rows"]) == 2 and b["effective_dof"] < 20
    doc = dry.to_json() | {"budget": budget, "result_id": 1}
    lines = [line for line in summary_lines(doc) if line.lstrip().startswith("damped-fit  ")]
    assert len(lines) == 2 and all("(U " in line and ", ν " in line for line in lines), lines


def test_runs_that_disagree_beyond_their_sigma_raise_the_pooled_sigma_by_the_birge_ratio():
    """The inverse-variance mean's σ 1/√Σw holds only if the runs agree within their σ; two
    runs 10 σ apart have χ² = 50 on ν 1 (R_B = √50): the headline σ is R_B/√Σw and the seed
    budget carries the part beyond 1/√Σw as its own row; runs within their σ add nothing."""
    from estimation.pendulum.pendulum_estimate import _scatter

    w = np.array([1.0, 1.0])  # σ 1 each: 1/√Σw = 1/√2
    assert _scatter(np.array([0.0, 0.5]), w) == (0.0, 1)  # χ² = 0.125 < ν
    part, dof = _scatter(np.array([0.0, 10.0]), w)
    assert dof == 1 and math.hypot(1 / math.sqrt(2), part) == pytest.approx(math.sqrt(50 / 2))
    assert _scatter(np.array([3.0]), np.array([1.0]))[0] == 0.0  # one run: no scatter to see


@pytest.mark.parametrize("gamma", [0.0, 40.0])
def test_a_biased_seed_headline_says_so_against_the_output_error_fit(gamma):
    """A damped sinusoid is linear: on swings of 0.15 and 0.3 rad its α and β sit 3–5 σ of the
    difference from the output-error fit after the search (sin φ's lower frequency at large
    swings; with γ, the quadratic drag taken into β), which its U does not cover: the
    result names the method as biased and the result to sign (``stats.method_bias``). The
    equation-error regression, which models both, is named in none. Three noise seeds."""
    for seed in range(3):
        runs = [
            decay(gamma=gamma, amplitude=a, seed=100 * seed + k, run_id=f"p{k}")
            for k, a in ((1, 0.15), (2, 0.3))
        ]
        for method, biased in (("damped-fit", True), ("equation-error", False)):
            said = [w for w in estimate_pendulum(runs, method=method).warnings if "biased" in w]
            assert bool(said) == biased, (gamma, seed, method, said)
            if biased:
                assert said[0].startswith(f"{method} is biased on these runs: ")
                assert "sign the output-error result" in said[0]


def test_every_seed_row_is_compared_with_the_output_error_row_of_its_run():
    """With 0.01 N·m of pivot friction on a 60 s swing, the output-error search finds it and
    every seed method's β takes it up (2.7–6.6 σ off); on the clean swing only damped-fit's
    α sits off (sin φ's lower frequency). Each seed row carries its z per coefficient and the
    largest one (what the report's and the page's column show); one warning names every row
    beyond ``DISAGREES_SIGMAS``, with the headline on output error, and no row within it."""
    for friction, named in ((0.01, set(SEED_ROWS)), (0.0, {"damped-fit"})):
        result = estimate_pendulum([decay(dry_friction=friction, duration=60.0)])
        assert result.method == "output-error"
        reference = next(m for m in result.section.methods if m.method == "output-error")
        assert reference.against_output_error is None and reference.vs_output_error == "—"
        far = set()
        for m in (m for m in result.section.methods if m.method in SEED_ROWS):
            z = m.against_output_error
            # γ only where output error has one (the search kept quadratic damping)
            assert set(z) == set(m.coefficients) & set(reference.coefficients)
            for name in z:
                seed, ref = m.coefficients[name], reference.coefficients[name]
                expected = abs(seed.value - ref.value) / math.hypot(seed.std, ref.std)
                assert z[name] == pytest.approx(expected)
            worst = max(z, key=z.__getitem__)
            assert m.to_json()["vs_output_error"] == f"{z[worst]:.1f} σ ({SYMBOLS[worst]})"
            if max(z.values()) > DISAGREES_SIGMAS:
                far.add(m.method)
        assert far == named, friction
        (said,) = [w for w in result.warnings if w.startswith("method rows further than")]
        assert all(f"{method} on run p1: " in said for method in far)
        assert all(f"{method} on run p1: " not in said for method in set(SEED_ROWS) - far)
