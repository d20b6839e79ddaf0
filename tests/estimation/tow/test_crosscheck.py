"""Cross-check of weight- vs thruster-driven estimation results, and its diagnosis."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest

from estimation import estimate
from estimation.axis.crosscheck_report import markdown, write_crosscheck_report
from estimation.axis.drive_crosscheck import _effects, cross_check
from estimation.design.planning_envelope import AxisEnvelope, RigEnvelope
from estimation.thrust.curve import ThrustCurve
from estimation.thrust.drive import curve_draws
from tests.estimation.synth import SURGE_TRUTH, Physics, thruster_run, tow_set

NAMES = ("inertia", "linear_damping", "quadratic_damping")


def _doc(
    values, stds, *, axis="surge", effects=(), draws=0, rmse=(1e-3, 1e-4), rho=None, warnings=()
) -> dict:
    extra = {}
    if rho is not None:  # ρ(K_L, K_Q); inertia uncorrelated
        matrix = np.eye(3)
        matrix[1, 2] = matrix[2, 1] = rho
        extra["correlation"] = {"names": list(NAMES), "matrix": matrix.tolist()}
    return extra | {
        "warnings": list(warnings),
        "axis": axis,
        "runs": ["a", "b"],
        "coefficients": {
            n: {"value": v, "std": s} for n, v, s in zip(NAMES, values, stds, strict=True)
        },
        "effects": [{"name": n, "value": v, "std": 0.01, "unit": "s"} for n, v in effects],
        "ambiguous": [],
        "rmse_before": rmse[0],
        "rmse_after": rmse[1],
        "uncertainty": {
            "calibration_draws": draws,
            "parameters": {
                n: {"std_fit": s, "std_calibration": 0.0, "std_total": s}
                for n, s in zip(NAMES, stds, strict=True)
            },
        },
    }


def test_equal_within_sigma_agree():
    w = _doc((143.0, 20.0, 241.0), (2.0, 3.0, 4.0))
    t = _doc((145.0, 17.0, 236.0), (2.0, 3.0, 5.0), draws=30)
    check = cross_check(w, t)
    doc = check.to_json()
    assert doc["verdict"] == "agree"
    assert all(abs(c["z"]) < 2 for c in doc["coefficients"].values())
    assert doc["coefficients"]["inertia"]["z"] == pytest.approx(2.0 / np.hypot(2, 2))
    assert doc["diagnosis"][0].startswith("weight- and thruster-driven coefficients agree")
    assert doc["warnings"] == []
    assert "| inertia (kg) |" in markdown(check)


def test_thrusters_weaker_than_calibrated_are_diagnosed_as_the_calibration(tmp_path):
    phys = Physics(*SURGE_TRUTH)
    weight = estimate(tow_set(phys, drives=(24.5, 44.1, 83.3)), n_bootstrap=0).to_json()
    # The thrusters push 1/1.10 of what their calibration (gain known to 1 %) says: the
    # recorded drive is F, the vehicle feels F/1.10, the coefficients come out ×1.10.
    values = np.array([50.0, 0.05, 0.8, 39.0, 0.05, 0.8, 0.0])
    std = np.zeros(7)
    std[0] = 0.01 * values[0]
    curve = ThrustCurve(values, std, np.eye(7), 0.1, -0.8, 0.8)
    draws = curve_draws(curve, 30)
    runs = []
    for f in (30.0, 60.0):
        run = thruster_run(phys, (f / 1.10,), hold_s=6.0, run_id=f"thr-{f:g}")
        drive = np.asarray(run.drive) * 1.10
        command = curve.command_for_force(drive / 2)
        alt = np.array([2 * c.force(command) for c in draws])
        runs.append(replace(run, drive=drive, drive_draws=alt))
    thrusters = estimate(runs, n_bootstrap=0).to_json()
    check = cross_check(weight, thrusters, supply_voltage_v={"calibration": 16.0, "runs": 14.9})
    doc = check.to_json()
    print("\n" + markdown(check))
    assert doc["verdict"] == "disagree"
    factor = doc["common_factor"]
    assert factor["k"] == pytest.approx(1.10, rel=0.01)
    assert factor["thrust_factor"] == pytest.approx(1 / 1.10, rel=0.01)
    assert factor["std"] == pytest.approx(0.011, rel=0.5)  # the calibration's 1 %
    assert factor["consistent"] and factor["significant"]
    assert "recalibrate" in doc["diagnosis"][0]
    assert "0.909 ± 0.0" in doc["diagnosis"][0]  # delivered / calibrated thrust
    assert "14.90 V vs 16.00 V at calibration" in doc["diagnosis"][0]
    assert not any(d.startswith("unexplained") for d in doc["diagnosis"])
    files = write_crosscheck_report(check, tmp_path)
    assert [f.name for f in files] == ["report.md", "crosscheck.png", "crosscheck.svg"]
    assert files[1].stat().st_size > 5000
    svg = files[2].read_text(encoding="utf-8")
    for label in ("inertia [kg]", "K_L [N·s/m]", "K_Q [N·s²/m²]"):
        assert label in svg  # the y axes name the coefficient and its unit
    md = files[0].read_text(encoding="utf-8")
    assert "![" in md and "(crosscheck.png)" in md and "(crosscheck.svg)" in md


def test_different_effects_are_named():
    w = _doc((143.0, 20.0, 241.0), (0.5, 0.5, 0.5))
    t = _doc((150.0, 20.0, 241.0), (0.5, 0.5, 0.5), effects=[("release_delay", 0.15)])
    doc = cross_check(w, t).to_json()
    assert doc["coefficients"]["inertia"]["verdict"] == "disagree"
    assert any("release_delay (0.15)" in d and "only the thruster" in d for d in doc["diagnosis"])
    assert not any(d.startswith("unexplained") for d in doc["diagnosis"])


def test_disagreement_without_a_common_factor_is_unexplained():
    w = _doc((143.0, 20.0, 241.0), (0.5, 0.5, 0.5))
    t = _doc((160.0, 20.0, 241.0), (0.5, 0.5, 0.5))
    doc = cross_check(w, t).to_json()
    assert doc["common_factor"]["consistent"] is False
    assert doc["diagnosis"][0].startswith("unexplained: inertia (z = +24.0)")


def test_bad_documents_name_the_field():
    w = _doc((143.0, 20.0, 241.0), (1, 1, 1))
    with pytest.raises(ValueError, match=r"thruster_result\.axis: 'yaw'"):
        cross_check(w, _doc((8.0, 0.1, 4.0), (1, 1, 1), axis="yaw"))
    with pytest.raises(ValueError, match="weight_result: not an estimation result"):
        cross_check({"table": []}, w)
    pendulum = {"analysis": "pendulum", "axis": "surge", "coefficients": {}}  # schema 1
    with pytest.raises(ValueError, match="weight_result: a pendulum estimation; allowed"):
        cross_check(pendulum, w)
    decay = {"kind": "decay", "dof": "surge", "coefficients": {}}  # schema 2 names every kind
    with pytest.raises(ValueError, match="thruster_result: a decay estimation; allowed: an "):
        cross_check(w, decay)


# --- sets that cannot separate K_L from K_Q -------------------------------------------------

ONE_FORCE = "K_L and K_Q are not separable from one force (ρ = -1.000): add a run at …"


def _steady_speed(phys: Physics, force: float) -> float:
    """|v| where K_L·v + K_Q·v² = force."""
    a, b = phys.quadratic_damping, phys.linear_damping
    return (-b + np.sqrt(b * b + 4 * a * force)) / (2 * a)


@pytest.fixture(scope="module")
def weight_doc() -> dict:
    """Four weight runs on the clean simulated rig, estimated for real."""
    return estimate(tow_set(Physics(*SURGE_TRUTH)), n_bootstrap=0).to_json()


def _thrusters(phys: Physics, forces, *, delivered: float = 1.0) -> dict:
    """Thruster tows at ``forces`` (one run each) as recorded; the vehicle feels
    ``delivered`` × the recorded thrust."""
    runs = []
    for f in forces:
        run = thruster_run(phys, (f * delivered,), hold_s=6.0, run_id=f"thr-{f:g}")
        runs.append(replace(run, drive=np.asarray(run.drive) / delivered))
    return estimate(runs, n_bootstrap=0).to_json()


def test_one_thruster_level_leaves_K_L_and_K_Q_undecided_with_the_run_that_decides(
    weight_doc, tmp_path
):
    phys = Physics(*SURGE_TRUTH)
    thrusters = _thrusters(phys, (36.0,))
    rho = thrusters["correlation"]["matrix"][1][2]
    assert abs(rho) > 0.95  # the estimator's own SEPARABILITY_LIMIT
    check = cross_check(weight_doc, thrusters)
    doc = check.to_json()
    assert doc["verdict"] == "agree"
    assert doc["undecided"] == ["linear_damping", "quadratic_damping"]
    for name in ("linear_damping", "quadratic_damping"):
        c = doc["coefficients"][name]
        assert c["verdict"] == "undecided"
        assert "the thruster set has one drive level" in c["reason"]
        assert f"ρ = {rho:+.4f}" in c["reason"]
        assert "add a thruster tow at a clearly different force" in c["reason"]
    assert doc["coefficients"]["inertia"]["verdict"] == "agree"
    # What one level does fix: the damping at its own speed, compared instead.
    combined = doc["combined"]["damping_at_speed"]
    assert combined["verdict"] == "agree"
    v = _steady_speed(phys, 36.0)
    assert combined["speed"] == pytest.approx(v, rel=0.1)
    truth = phys.linear_damping + phys.quadratic_damping * combined["speed"]
    assert combined["thruster"]["value"] == pytest.approx(truth, rel=1e-3)
    # fixed far better than either coefficient alone
    k_l = doc["coefficients"]["linear_damping"]["thruster"]
    assert combined["thruster"]["std"] / truth < 0.1 * k_l["std"] / k_l["value"]
    assert doc["common_factor"]["coefficients"] == ["inertia", "damping_at_speed"]
    assert not any("unexplained" in d or "disagree" in d for d in doc["diagnosis"])
    assert any(d.startswith("K_L, K_Q undecided: the thruster set") for d in doc["diagnosis"])
    md = markdown(check)
    assert "| **undecided** |" in md and "Undecided K_L, K_Q: the thruster set" in md
    # The document's label is the report's spelling (the page shows the document's).
    assert combined["label"] == f"K_L + K_Q·|v| at |v| = {combined['speed']:.3g} m/s"
    assert combined["label"] in md
    assert doc["coefficients"]["linear_damping"]["label"] == "K_L"
    files = write_crosscheck_report(check, tmp_path)
    assert files[1].stat().st_size > 5000


def test_two_thruster_levels_get_real_verdicts(weight_doc):
    thrusters = _thrusters(Physics(*SURGE_TRUTH), (18.0, 72.0))
    assert abs(thrusters["correlation"]["matrix"][1][2]) < 0.95
    doc = cross_check(weight_doc, thrusters).to_json()
    assert doc["undecided"] == [] and doc["combined"] == {}
    assert {c["verdict"] for c in doc["coefficients"].values()} == {"agree"}
    assert doc["common_factor"]["coefficients"] == list(NAMES)


def test_weak_thrusters_at_one_level_still_point_at_the_calibration(weight_doc):
    # The vehicle feels 0.85× the recorded thrust: every coefficient reads 1/0.85× high.
    thrusters = _thrusters(Physics(*SURGE_TRUTH), (36.0,), delivered=0.85)
    doc = cross_check(weight_doc, thrusters).to_json()
    assert doc["verdict"] == "disagree"
    assert doc["coefficients"]["inertia"]["verdict"] == "disagree"
    assert doc["combined"]["damping_at_speed"]["verdict"] == "disagree"
    assert doc["coefficients"]["linear_damping"]["verdict"] == "undecided"
    factor = doc["common_factor"]
    assert factor["coefficients"] == ["inertia", "damping_at_speed"]
    assert factor["thrust_factor"] == pytest.approx(0.85, abs=0.01)
    assert "recalibrate" in doc["diagnosis"][0]
    assert not any(d.startswith("unexplained") for d in doc["diagnosis"])


def test_a_collinear_pair_off_along_its_ridge_is_undecided_not_unexplained():
    # One level fixes K_L + K_Q·|v| at |v| ≈ 0.345: the thruster K_L/K_Q moved along that
    # ridge (ΔK_L = −|v|·ΔK_Q), far beyond their individual σ (K_L z ≈ −6).
    w = _doc((143.0, 20.16, 241.14), (0.05, 0.01, 0.03), rho=-0.77)
    t = _doc((143.1, 19.0, 244.5), (0.1, 0.19, 0.55), rho=-0.998, warnings=[ONE_FORCE])
    assert cross_check(_doc((143.0, 20.16, 241.14), (0.05, 0.01, 0.03)), _old(t)).verdict == (
        "disagree"
    )  # what the individual σ alone would say
    doc = cross_check(w, t).to_json()
    assert doc["coefficients"]["linear_damping"]["z"] < -6
    assert doc["coefficients"]["linear_damping"]["verdict"] == "undecided"
    assert doc["combined"]["damping_at_speed"]["speed"] == pytest.approx(0.998 * 0.19 / 0.55)
    assert doc["combined"]["damping_at_speed"]["verdict"] == "agree"
    assert doc["verdict"] == "agree"
    assert not any("unexplained" in d for d in doc["diagnosis"])


def test_high_correlation_without_one_level_says_the_levels_do_not_separate():
    w = _doc((143.0, 20.16, 241.14), (0.05, 0.01, 0.03), rho=-0.96)
    t = _doc((143.0, 20.16, 241.14), (0.05, 0.01, 0.03), rho=-0.5)
    doc = cross_check(w, t).to_json()
    reason = doc["coefficients"]["quadratic_damping"]["reason"]
    assert reason.startswith("the weight set's drive levels do not separate K_L from K_Q")
    assert "add a weight run well outside the forces it covers" in reason


def test_both_sets_stuck_at_different_speeds_compare_nothing_but_inertia():
    w = _doc((143.0, 20.16, 241.14), (0.05, 0.19, 0.55), rho=-0.998, warnings=[ONE_FORCE])
    t = _doc((143.0, 22.0, 236.0), (0.05, 0.19, 0.40), rho=-0.999, warnings=[ONE_FORCE])
    doc = cross_check(w, t).to_json()
    assert doc["combined"]["damping_at_speed"]["verdict"] == "undecided"
    assert "ran at different speeds" in doc["combined"]["damping_at_speed"]["reason"]
    assert doc["common_factor"]["coefficients"] == ["inertia"]
    assert doc["verdict"] == "agree"


def _old(doc: dict) -> dict:
    """A document as stored before correlation and warnings were read by the cross-check."""
    return {k: v for k, v in doc.items() if k not in ("correlation", "warnings")}


def test_old_documents_without_correlation_still_load():
    w = _old(_doc((143.0, 20.0, 241.0), (2.0, 3.0, 4.0)))
    t = _old(_doc((145.0, 17.0, 236.0), (2.0, 3.0, 5.0)))
    doc = cross_check(w, t).to_json()
    assert doc["verdict"] == "agree" and doc["undecided"] == [] and doc["combined"] == {}


def test_a_term_inseparable_from_k_l_is_an_ambiguous_effect_and_k_l_is_not_one():
    doc = {
        "effects": [{"name": "coulomb_friction", "value": 3.0}],
        "ambiguous": [["constant_bias", "linear_damping"]],
    }
    found = _effects(doc)
    assert set(found) == {"coulomb_friction", "constant_bias"}
    assert found["coulomb_friction"] == 3.0 and np.isnan(found["constant_bias"])


def test_with_the_rigs_envelope_the_undecided_advice_is_a_thruster_tow_the_rig_can_run(
    weight_doc,
):
    """The planner's envelope (estimation.design) replaces "0.25× or 4× the current": the
    thruster tow it names is inside the calibrated range (here −20…48 N, so 4× 36 N = 144 N
    would be beyond it), clearly different from 36 N, and given as a command."""
    phys = Physics(*SURGE_TRUTH)
    thrusters = _thrusters(phys, (36.0,))
    surge = AxisEnvelope("surge", 100.0, 5.5, 5.3, max_rate=1.0, thruster_range=(-20.0, 48.0))
    check = cross_check(weight_doc, thrusters, envelope=RigEnvelope((surge,), g=9.8))
    reason = check.to_json()["coefficients"]["linear_damping"]["reason"]
    (force,) = [float(x) for x in re.findall(r"rig tow --force (-?[0-9.]+) --thrusters", reason)]
    assert 0 < force <= 48.0
    assert max(force / 36.0, 36.0 / force) >= 1.5
    assert "4×" not in reason


def test_a_coefficient_a_set_gives_no_sigma_for_is_undecided_naming_that_set():
    """ls-steady through two weight tows gives K_L and K_Q no σ (its drag law has no
    residual): they, and the damping at the thruster set's speed built from them, are
    undecided naming the weight set, not judged "agree" on the thruster set's σ alone or
    listed among what both sets decide; the report prints "σ not known", never "± nan"."""
    phys = Physics(*SURGE_TRUTH)
    weight = estimate(tow_set(phys, drives=(24.5, 44.1)), method="ls-steady", n_bootstrap=0)
    assert weight.to_json()["coefficients"]["linear_damping"]["std"] is None
    check = cross_check(weight.to_json(), _thrusters(phys, (36.0,)))
    doc = check.to_json()
    rows = {**doc["coefficients"], **doc["combined"]}
    for name in ("linear_damping", "quadratic_damping", "damping_at_speed"):
        assert rows[name]["verdict"] == "undecided", rows[name]
        assert rows[name]["reason"].startswith("the weight set has no σ for it"), rows[name]
    assert doc["coefficients"]["inertia"]["verdict"] == "agree"
    assert doc["verdict"] == "agree" and doc["undecided"] == ["linear_damping", "quadratic_damping"]
    assert "on what both decide (inertia; all |z| < 2)" in doc["diagnosis"][0]
    md = markdown(check)
    assert "nan" not in md and md.count("(σ not known)") == 3
