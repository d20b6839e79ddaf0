"""Every pendulum seed-method row carries U = t_0.975(ν)·σ (``pendulum.methods``), and a
seed method's headline has a budget (``pendulum_estimate.seed_budget``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from api.cli.estimate import summary_lines
from estimation.pendulum.methods import UNCERTAINTY_NOTE
from estimation.pendulum.pendulum_estimate import estimate_pendulum, pendulum_budget
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
