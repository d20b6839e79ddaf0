"""The budget's arithmetic (Welch–Satterthwaite, k, ITTC rounding), declared tolerances,
and the repeat-run rules (grouping by condition, Chauvenet's criterion)."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from daq.config import DEFAULT_RIG_FILE, RigConfigError, parse_rig
from estimation import RunData, estimate
from estimation.axis.tow_repeats import analyse_tow_repeats, group_conditions, terminal_speed
from estimation.stats.repeatability import chauvenet
from estimation.theory.measured import HullScale, measured_beside_theory
from estimation.uncertainty import Chain, TowRefits, check_tolerances, uncertainty_budget
from estimation.uncertainty.budget import coverage_factor, effective_dof, round_reported
from estimation.uncertainty.sources import ToleranceError
from estimation.uncertainty.type_a import QUANTIZATION
from estimation.water import water_properties
from tests.estimation.synth import SURGE_TRUTH, Physics, weight_run
from tests.estimation.term_cases import tow_set


def test_welch_satterthwaite_and_the_coverage_factor():
    # two equal contributions, one with ν = 4, one exact: ν_eff = (2u²)² / (u⁴/4) = 16
    assert effective_dof([1.0, 1.0], [4.0, math.inf]) == pytest.approx(16.0)
    assert effective_dof([1.0], [math.inf]) == math.inf
    assert coverage_factor(math.inf) == pytest.approx(1.960, abs=5e-4)
    assert coverage_factor(16.0) == pytest.approx(2.120, abs=5e-4)  # t table, 95 %, ν = 16
    assert coverage_factor(2.0) == pytest.approx(4.303, abs=5e-4)


@pytest.mark.parametrize(
    ("value", "expanded", "shown"),
    [
        (143.1426, 0.5312, ("143.14", "0.54")),  # U rounded up to 2 digits, value to match
        (7.96712, 0.05664, ("7.967", "0.057")),
        (241.14, 2.465, ("241.1", "2.5")),
        (20.16, 0.75, ("20.16", "0.75")),  # exactly two digits stays
        (1234.5, 99.6, ("1230", "100")),  # rounding up past a decade
    ],
)
def test_expanded_uncertainty_is_reported_to_two_significant_digits(value, expanded, shown):
    assert round_reported(value, expanded) == shown


def test_declared_tolerances_are_checked_naming_the_field():
    assert check_tolerances({"g_m_s2": 0.02}) == {"g_m_s2": 0.02}
    with pytest.raises(ToleranceError, match=r"tolerances.g_m_s2: got -1.*>= 0"):
        check_tolerances({"g_m_s2": -1})
    with pytest.raises(ToleranceError, match=r"tolerances.pulley_mass.*hung_mass_kg"):
        check_tolerances({"pulley_mass": 0.1})


def test_the_rig_file_declares_tolerances_and_refuses_a_bad_one_in_one_line():
    data = tomllib.loads(DEFAULT_RIG_FILE.read_text())
    rig = parse_rig(data)
    assert rig.tolerances is not None and rig.tolerances.declared()["hung_mass_kg"] == 0.005
    data["tolerances"]["encoder_scale_rel"] = 0.5
    with pytest.raises(RigConfigError, match=r"tolerances.encoder_scale_rel: .*0.1 \(got 0.5\)"):
        parse_rig(data)
    del data["tolerances"]
    assert parse_rig(data).tolerances is None


def _run(run_id: str, force: float) -> RunData:
    t = np.arange(0, 5, 0.1)
    return RunData(run_id, "surge", t, 0.1 * t, force, hung_mass_kg=abs(force) / 9.8)


def test_runs_at_the_same_condition_are_grouped_within_one_percent():
    runs = [_run("a", 24.5), _run("b", 44.1), _run("c", 24.6), _run("d", -24.5), _run("e", 26)]
    groups = [[runs[i].run_id for i in g] for g in group_conditions(runs)]
    assert sorted(groups) == sorted([["a", "c"], ["b"], ["d"], ["e"]])


def test_chauvenet_flags_only_the_outlying_repeat():
    speeds = [0.500, 0.502, 0.498, 0.501, 0.499, 0.500, 0.530]
    assert chauvenet(speeds) == [False] * 6 + [True]
    assert chauvenet([0.5, 0.6]) == [False, False]  # two repeats cannot say which is wrong
    assert chauvenet([0.5, 0.501, 0.499]) == [False, False, False]


def test_repeats_that_differ_by_reading_noise_alone_are_not_outliers():
    """Five repeats of one BENBAM tow that differ only in their noise and clock jitter, 50
    seeds: the criterion alone flags a repeat in several sets (about 13 %), the tows' rule
    with each terminal speed's reading σ as its floor in none; a wrong weight 4 % heavier is
    still flagged (test_uncertainty_chain)."""
    alone = floored = 0
    for seed in range(50):
        rng = np.random.default_rng(seed)
        runs = [weight_run(Physics(*SURGE_TRUTH), 44.1, run_id=f"r{k}", rng=rng) for k in range(5)]
        speeds = [terminal_speed(r)[0] for r in runs]
        alone += any(chauvenet(speeds))
        floored += bool(analyse_tow_repeats(runs).outliers)
    assert alone >= 3, f"the criterion alone flagged {alone} of 50 sets"
    assert floored == 0, f"{floored} of 50 sets of noise-only repeats had an outlier"


def test_added_mass_and_its_coefficient_carry_the_vehicle_and_water_tolerances():
    """m_a = 40 − 30 kg with u_c = 0.1 kg (ν = ∞) and a body known to u = 0.1 kg: u(m_a) =
    0.1·√2; ∇ known to 1 %: u(C_a)/C_a = √((0.1·√2/10)² + 0.01²). Against a predicted 5 kg the
    ratio 2 sits on the band's edge (plausible); Re = U L/ν at 15 °C."""
    water = water_properties(15.0)
    hull = HullScale(
        length_m=1.0,
        volume_m3=0.03,
        reference_area_m2=0.05,
        body_inertia=30.0,
        predicted_added=5.0,
        u_body=0.1,
        u_volume=0.0003,
    )
    doc = measured_beside_theory(
        "surge",
        {"inertia": (40.0, 0.1, None), "quadratic_damping": (200.0, 1.0, None)},
        {"r1": 0.5},
        water,
        hull,
        9.81,
    )
    added = doc["added"]
    assert added["value"] == pytest.approx(10.0)
    assert added["expanded_uncertainty"] == pytest.approx(1.96 * 0.1 * math.sqrt(2), rel=1e-3)
    c_a = doc["dimensionless"]["C_a = m_a / (ρ ∇)"]
    assert c_a["value"] == pytest.approx(10.0 / (water.density * 0.03))
    rel = math.sqrt((0.1 * math.sqrt(2) / 10) ** 2 + 0.01**2)
    assert c_a["expanded_uncertainty"] == pytest.approx(1.96 * rel * c_a["value"], rel=1e-3)
    assert doc["runs"]["r1"]["reynolds"] == pytest.approx(0.5 / water.kinematic_viscosity)
    assert doc["theory"]["ratio"] == pytest.approx(2.0) and doc["theory"]["plausible"]


def test_the_encoder_quantization_row_is_the_fits_and_counted_once():
    """Clean 143 kg tows on a 0.1 mm grid (tests/estimation/term_cases.py): the budget lists
    the fit's quantization σ beside its white σ, and u_c is the larger of them alone (the
    same noise of the samples: not root-sum-squared); runs off any grid have no such row."""
    runs = tow_set("143kg", seed=300)
    result = estimate(runs, search_effects=False, n_bootstrap=0)
    fit = result.fit_after
    assert fit is not None and fit.std_quantization is not None and fit.std_white is not None
    budget = uncertainty_budget(result, TowRefits(runs, result, None), None)
    for i, name in enumerate(fit.names):
        coefficient = budget.coefficients[name]
        rows = {r.source: r for r in coefficient.rows}
        assert rows[QUANTIZATION].standard_uncertainty == pytest.approx(fit.std_quantization[i])
        larger = max(fit.std_quantization[i], fit.std_white[i])
        assert coefficient.combined_std == pytest.approx(larger)
        assert sum(r.combined for r in coefficient.rows) == 1
    rng = np.random.default_rng(1)
    off_grid = [
        RunData(
            r.run_id,
            r.axis,
            r.t,
            r.position + 2e-5 * rng.standard_normal(r.t.size),
            r.drive,
            t_release=r.t_release,
        )
        for r in runs
    ]
    result = estimate(off_grid, search_effects=False, n_bootstrap=0)
    assert result.fit_after is not None and result.fit_after.std_quantization is None
    rows = (
        uncertainty_budget(result, TowRefits(off_grid, result, None), None)
        .coefficients["inertia"]
        .rows
    )
    assert QUANTIZATION not in {r.source for r in rows}


def test_without_inputs_that_move_the_runs_the_fit_row_is_the_estimates_own_sigma():
    """AR(1) position noise (ρ 0.9, ``test_term_coverage.correlated_noise``) on clean 143 kg
    tows without a rig file: nothing declared carries the residual's structure, so the fit
    row is the estimate's σ with the residual's correlation (ν = n_eff − p) and u_c is never
    below the σ the estimate reports (the white σ alone is over 1.5× smaller here). With an
    encoder scale's tolerance declared the row is the white σ, the structure being the
    declared inputs' (the type_a module's rule)."""
    from dataclasses import replace

    from estimation.uncertainty.type_a import FIT_SERIAL, FIT_WHITE
    from tests.estimation.term_search.test_term_coverage import correlated_noise

    runs = [
        replace(r, position=r.position + correlated_noise(r.t.size, 900 + i, rho=0.9))
        for i, r in enumerate(tow_set("143kg", seed=301))
    ]
    result = estimate(runs, search_effects=False, n_bootstrap=0)
    fit = result.fit_after
    assert fit is not None and fit.std_white is not None
    assert np.all(fit.std > 1.5 * fit.std_white)  # the structure the white σ misses
    budget = uncertainty_budget(result, TowRefits(runs, result, None), None)
    for i, name in enumerate(fit.names):
        b = budget.coefficients[name]
        (row,) = [r for r in b.rows if r.combined]
        assert row.source == FIT_SERIAL and b.combined_std >= fit.std[i] * (1 - 1e-12), name
        assert row.dof < fit.n_samples / 5  # n_eff of a ρ 0.9 residual is ~n/19
    scale = {"encoder_scale_rel": 0.002}
    declared = uncertainty_budget(result, TowRefits(runs, result, Chain(g=9.81)), scale)
    assert FIT_WHITE in {r.source for r in declared.coefficients["inertia"].rows}
