"""Sensitivity, knock-out, threshold sweep and identifiability on the real 6-DOF simulator."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from estimation import estimate
from estimation.vehicle.ahp import hierarchy
from estimation.vehicle.description import Vehicle6
from estimation.vehicle.identifiability import analyse_identified, assess, plug_results, run_speed
from estimation.vehicle.responses import ResponseError, evaluate
from estimation.vehicle.sensitivity import SensitivityError, analyse
from estimation.vehicle.vehicle_file import load_vehicle
from tests.estimation.synth import tow_set

VEHICLES = Path(__file__).parents[3] / "fixtures" / "vehicles"
#: Surge model of the decoupled test body: K_L·u + K_Q·u² = F at steady state.
MASS, K_L, K_Q, FORCE = 10.0, 5.0, 20.0, 10.0


def decoupled(**coefficients) -> Vehicle6:
    """A neutrally buoyant body with CG = CB = origin and equal translational added mass:
    a pure surge force moves it in surge only (no Munk moment, no restoring coupling)."""
    values = {
        "added_mass": (4.0, 4.0, 4.0, 0.2, 0.3, 0.3),
        "linear_damping": (K_L, 8.0, 9.0, 0.5, 0.6, 0.7),
        "quadratic_damping": (K_Q, 30.0, 31.0, 1.0, 1.2, 1.5),
    } | coefficients
    return Vehicle6(
        name="decoupled",
        mass_kg=MASS,
        inertia_kg_m2=(0.4, 0.6, 0.6),
        cg_m=(0.0, 0.0, 0.0),
        cb_m=(0.0, 0.0, 0.0),
        buoyancy_n=100.0,
        g=10.0,
        thrusters=(),
        **values,
    )


def steady_speed(k_l: float, k_q: float, f: float) -> float:
    return (-k_l + math.sqrt(k_l**2 + 4 * k_q * f)) / (2 * k_q) if k_q > 0 else f / k_l


def test_normalized_sensitivity_of_steady_speed_matches_closed_form():
    report = analyse(decoupled(), ["steady_surge_speed"], forces={"surge": FORCE})
    u = steady_speed(K_L, K_Q, FORCE)
    assert report.reference["steady_surge_speed"] == pytest.approx(u, rel=1e-5)
    # F = K_L u + K_Q u² → ∂ln u/∂ln K_L = −K_L/(K_L + 2 K_Q u), ∂ln u/∂ln K_Q = −K_Q u/(…)
    denominator = K_L + 2 * K_Q * u
    s_kl = report.row("linear_damping.surge").s["steady_surge_speed"]
    s_kq = report.row("quadratic_damping.surge").s["steady_surge_speed"]
    assert s_kl == pytest.approx(-K_L / denominator, abs=2e-4)
    assert s_kq == pytest.approx(-K_Q * u / denominator, abs=2e-4)
    # knock-out of K_L: u₀ = √(F/K_Q)
    sc = report.row("linear_damping.surge").sc["steady_surge_speed"]
    assert sc == pytest.approx(abs(u - math.sqrt(FORCE / K_Q)) / u, rel=1e-4)
    # the steady speed does not depend on the added mass
    assert abs(report.row("added_mass.surge").s["steady_surge_speed"]) < 1e-4


def test_rise_time_scales_with_total_inertia():
    """Linear damping only: t90 = (m + a)/K_L·ln 10, so S(a) = a/(m + a) and S(K_L) = −1."""
    body = decoupled(quadratic_damping=(0.0, 30.0, 31.0, 1.0, 1.2, 1.5))
    report = analyse(body, ["surge_rise_time_90"], forces={"surge": FORCE})
    added = body.added_mass[0]
    t90 = (MASS + added) / K_L * math.log(10)
    assert report.reference["surge_rise_time_90"] == pytest.approx(t90, rel=1e-3)
    s = report.row("added_mass.surge").s["surge_rise_time_90"]
    assert s == pytest.approx(added / (MASS + added), abs=5e-3)
    assert report.row("linear_damping.surge").s["surge_rise_time_90"] == pytest.approx(
        -1.0, abs=5e-3
    )


def test_knock_out_of_an_unexcited_axis_gives_zero_by_simulation():
    report = analyse(decoupled(), ["steady_surge_speed", "distance_at_t"], forces={"surge": FORCE})
    for name in ("linear_damping.sway", "quadratic_damping.sway", "added_mass.heave"):
        row = report.row(name)
        assert max(row.sc.values()) < 1e-9, row
        assert row.composite < 1e-9
    # and every coefficient was really re-simulated: ref + 3 per non-zero coefficient + sweep
    n_coeffs = len(decoupled().coefficients())
    assert report.simulations >= 1 + 3 * n_coeffs


def test_threshold_sweep_removes_exactly_the_terms_below_and_resimulates():
    vehicle = load_vehicle(VEHICLES / "benbam.toml")
    base = analyse(vehicle, ["steady_surge_speed", "surge_rise_time_90", "turning_diameter"])
    affecting = [r for r in base.rows if 0 < r.composite < 1.0]
    assert affecting, "BENBAM should have coefficients with a small but non-zero effect"
    target = affecting[-1]  # the smallest non-zero composite
    threshold = target.composite * 1.0001
    keep = [affecting[0].name] if affecting[0] is not target else []
    report = analyse(
        vehicle,
        ["steady_surge_speed", "surge_rise_time_90", "turning_diameter"],
        thresholds=[threshold],
        keep=keep,
    )
    row = next(s for s in report.sweep if s.criterion == "composite" and s.threshold == threshold)
    expected = {r.name for r in report.rows if r.composite < threshold and r.name not in keep}
    assert set(row.removed) == expected
    assert target.name in row.removed
    # the errors are those of the reduced model, simulated independently here
    reduced = evaluate(vehicle.with_coefficients(dict.fromkeys(row.removed, 0.0)), report.plan)
    for name, err in row.errors.items():
        ref = report.reference[name]
        assert err == pytest.approx(abs(reduced[name].value - ref) / abs(ref), rel=1e-9, abs=1e-12)
    assert row.max_error > 0  # a removed term with Sc > 0 moves at least one response
    assert row.max_error == max(row.errors.values())
    # the "max" criterion removes only terms whose every single-response Sc is below
    row_max = next(s for s in report.sweep if s.criterion == "max" and s.threshold == threshold)
    assert set(row_max.removed) == {
        r.name for r in report.rows if r.max_sc < threshold and r.name not in keep
    }


def test_kept_coefficients_are_never_removed():
    vehicle = load_vehicle(VEHICLES / "benbam.toml")
    keep = ["linear_damping.sway", "added_mass.roll"]
    report = analyse(vehicle, ["steady_surge_speed"], thresholds=[1e6], keep=keep)
    for row in report.sweep:
        assert not set(keep) & set(row.removed)
    everything = [row for row in report.sweep if row.threshold == 1e6]
    assert len(everything) == 2  # composite and max criteria
    for row in everything:
        assert set(row.removed) == {r.name for r in report.rows} - set(keep)


def test_ahp_weights_make_the_composite_index():
    vehicle = load_vehicle(VEHICLES / "benbam.toml")
    names = ["steady_surge_speed", "steady_yaw_rate"]
    h = hierarchy([[1.0]], [([[1, 3], [1 / 3, 1]], names)])
    report = analyse(vehicle, names, weights=h)
    assert report.weights == pytest.approx({names[0]: 0.75, names[1]: 0.25})
    for row in report.rows:
        assert row.composite == pytest.approx(0.75 * row.sc[names[0]] + 0.25 * row.sc[names[1]])
    assert report.ahp is not None and report.ahp["cr"] == 0.0


def test_sigma_sensitivity_uses_the_vehicle_sigma():
    body = decoupled()
    body = Vehicle6(**{**body.__dict__, "sigma": {"quadratic_damping.surge": 2.0}})
    report = analyse(body, ["steady_surge_speed"], forces={"surge": FORCE})
    row = report.row("quadratic_damping.surge")
    u = steady_speed(K_L, K_Q, FORCE)
    expected = max(abs(steady_speed(K_L, K_Q + s, FORCE) - u) for s in (2.0, -2.0)) / u
    assert row.sigma_change["steady_surge_speed"] == pytest.approx(expected, rel=1e-3)
    assert report.row("linear_damping.surge").sigma_change is None


def test_bad_inputs_name_the_field():
    body = decoupled()
    with pytest.raises(SensitivityError, match=r"keep: 'drag\.surge' is not allowed"):
        analyse(body, ["steady_surge_speed"], forces={"surge": FORCE}, keep=["drag.surge"])
    with pytest.raises(SensitivityError, match=r"delta: 0\.9"):
        analyse(body, ["steady_surge_speed"], forces={"surge": FORCE}, delta=0.9)
    with pytest.raises(ResponseError, match="responses: 'speed' is not allowed"):
        analyse(body, ["speed"], forces={"surge": FORCE})
    with pytest.raises(ResponseError, match=r"no thrust along surge; give forces\.surge"):
        analyse(body, ["steady_surge_speed"])


# ---- identifiability ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def slow_tows():
    """Three light-weight tows (end speeds 0.06–0.11 m/s) of the BENBAM surge truth."""
    runs = tow_set(drives=(2.0, 3.0, 4.9), duration_s=20.0, quantum=0.005)
    return runs, estimate(runs, search_effects=False, n_bootstrap=0).to_json()


def test_run_speed_is_the_terminal_speed(slow_tows):
    runs, _ = slow_tows
    for run in runs:
        truth = steady_speed(20.16, 241.14, float(run.drive))
        assert run_speed(run) == pytest.approx(truth, rel=0.03)


def test_results_are_plugged_in_with_their_sigma(slow_tows):
    _, doc = slow_tows
    vehicle = plug_results(load_vehicle(VEHICLES / "benbam.toml"), [doc])
    c = doc["coefficients"]
    assert vehicle.total_inertia("surge") == pytest.approx(c["inertia"]["value"])
    assert vehicle.sigma["quadratic_damping.surge"] == c["quadratic_damping"]["std"]
    assert vehicle.sigma["added_mass.surge"] == c["inertia"]["std"]


def test_identifiability_ranks_larger_relative_sigma_first(slow_tows):
    _, doc = slow_tows
    doc = {**doc, "coefficients": {k: dict(v) for k, v in doc["coefficients"].items()}}
    doc["coefficients"]["linear_damping"]["std"] = (
        0.5 * doc["coefficients"]["linear_damping"]["value"]
    )
    report = analyse_identified(
        load_vehicle(VEHICLES / "benbam.toml"), [doc], responses=["steady_surge_speed"]
    )
    ident = report.identifiability
    assert ident["by_relative_sigma"][0] == "linear_damping.surge"
    rel = {c["name"]: c["relative_sigma"] for c in ident["coefficients"]}
    assert rel["linear_damping.surge"] == pytest.approx(0.5)
    assert list(rel.values()) != sorted(rel.values())  # ranked by weighted effect, not σ


def test_next_test_for_a_dominant_quadratic_sigma_is_a_high_force_tow(slow_tows):
    runs, doc = slow_tows
    doc = {**doc, "coefficients": {k: dict(v) for k, v in doc["coefficients"].items()}}
    kq = doc["coefficients"]["quadratic_damping"]
    kq["std"] = 0.3 * kq["value"]
    vehicle = plug_results(load_vehicle(VEHICLES / "benbam.toml"), [doc])
    report = analyse(vehicle, ["steady_surge_speed", "surge_rise_time_90"])
    ident = assess(report, vehicle, [doc], {"surge": [run_speed(r) for r in runs]})
    nxt = ident["next_test"]
    assert nxt["coefficient"] == "quadratic_damping.surge"
    assert "high-force tow" in nxt["test"]
    assert "barely reach the quadratic regime" in nxt["reason"]
    assert ident["coefficients"][0]["name"] == "quadratic_damping.surge"
    # the fit's K_L–K_Q correlation is flagged
    assert any(
        {c["a"], c["b"]} == {"linear_damping.surge", "quadratic_damping.surge"}
        for c in ident["correlations"]
    )
    # sway/heave/roll/pitch were never measured
    notes = {u["name"]: u["note"] for u in ident["unmeasured"]}
    assert notes["linear_damping.sway"] == "not measured: values are placeholders"


def test_next_test_for_a_dominant_inertia_sigma_is_an_acceleration_run(slow_tows):
    _, doc = slow_tows
    doc = {**doc, "coefficients": {k: dict(v) for k, v in doc["coefficients"].items()}}
    doc["coefficients"]["inertia"]["std"] = 0.2 * doc["coefficients"]["inertia"]["value"]
    report = analyse_identified(
        load_vehicle(VEHICLES / "benbam.toml"), [doc], responses=["surge_rise_time_90"]
    )
    nxt = report.identifiability["next_test"]
    assert nxt["coefficient"] == "added_mass.surge"
    assert "pendulum free-decay" in nxt["test"] and "acceleration-dominated tow" in nxt["test"]
    assert np.isfinite(report.identifiability["coefficients"][0]["weighted"])


def test_two_results_for_one_axis_are_refused(slow_tows):
    _, doc = slow_tows
    with pytest.raises(ValueError, match=r"results\[1\]: axis: a second result for 'surge'"):
        plug_results(load_vehicle(VEHICLES / "benbam.toml"), [doc, doc])


def test_cost_limits_stop_the_analysis():
    body = decoupled()
    with pytest.raises(SensitivityError, match=r"time_limit_s: the analysis took longer than 0 s"):
        analyse(body, ["steady_surge_speed"], forces={"surge": FORCE}, time_limit_s=0.0)
    with pytest.raises(ValueError, match=r"integrates in ≤ 5 steps"):
        analyse(body, ["steady_surge_speed"], forces={"surge": FORCE}, max_evaluations=5)


def test_distance_at_a_chosen_time_matches_the_linear_solution():
    """K_Q = 0: x(t) = v∞·(t − τ(1 − e^{−t/τ})), v∞ = F/K_L, τ = (m + a)/K_L."""
    body = decoupled(quadratic_damping=(0.0, 30.0, 31.0, 1.0, 1.2, 1.5))
    report = analyse(body, ["distance_at_t"], forces={"surge": FORCE}, distance_time_s=2.5)
    tau = (MASS + body.added_mass[0]) / K_L
    x = FORCE / K_L * (2.5 - tau * (1 - math.exp(-2.5 / tau)))
    assert report.plan.constants["distance_time_s"] == 2.5
    assert report.reference["distance_at_t"] == pytest.approx(x, rel=1e-4)
    with pytest.raises(ResponseError, match=r"distance_time_s: 1000\.0 is not allowed"):
        analyse(body, ["distance_at_t"], forces={"surge": FORCE}, distance_time_s=1000.0)


def test_weight_stability_names_the_removals_a_weight_change_flips():
    vehicle = load_vehicle(VEHICLES / "benbam.toml")
    names = ["steady_surge_speed", "steady_yaw_rate", "turning_diameter"]
    report = analyse(vehicle, names)
    assert report.weight_stability  # BENBAM's linear_damping.yaw sits near 0.01
    base = {
        t: {r.name for r in report.rows if r.candidate and r.composite < t}
        for t in (0.005, 0.0075, 0.01)
    }
    seen = set()
    for case in report.weight_stability:
        w = dict(report.weights)
        w[case["response"]] *= case["factor"]
        total = sum(w.values())
        removed = {
            r.name
            for r in report.rows
            if r.candidate and sum(r.sc[n] * w[n] / total for n in names) < case["threshold"]
        }
        assert removed - base[case["threshold"]] == set(case["now_removed"])
        assert base[case["threshold"]] - removed == set(case["now_kept"])
        seen.add((case["response"], case["factor"], case["threshold"]))
    # every (response, ×2 or ÷2, threshold) not listed changes nothing
    for n in names:
        for f in (2.0, 0.5):
            for t in base:
                if (n, f, t) in seen:
                    continue
                w = dict(report.weights)
                w[n] *= f
                total = sum(w.values())
                removed = {
                    r.name
                    for r in report.rows
                    if r.candidate and sum(r.sc[k] * w[k] / total for k in names) < t
                }
                assert removed == base[t]
    single = analyse(vehicle, ["steady_surge_speed"])
    assert single.weight_stability == ()


def test_a_knock_out_that_breaks_the_model_counts_as_infinite_in_strict_json():
    """seed 002's ROV has no restoring moment and no surge K_Q: without K_L.surge the
    surge step never settles and the vehicle pitches over (the simulator refuses ±90°)."""
    import json

    report = analyse_identified(
        load_vehicle(VEHICLES / "seed002-rov.toml"), [], responses=["steady_surge_speed"]
    )
    row = report.row("linear_damping.surge")
    assert row.composite == math.inf
    assert any(n.startswith("linear_damping.surge = 0: simulation failed") for n in report.notes)
    doc = json.loads(json.dumps(report.to_json(), allow_nan=False))
    ranked = {r["name"]: r for r in doc["ranking"]}
    assert ranked["linear_damping.surge"]["composite"] is None
    assert doc["ranking"][0]["composite"] is None  # ∞ ranks first
    for row in report.sweep:
        assert "linear_damping.surge" not in row.removed
