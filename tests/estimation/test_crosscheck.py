"""Cross-check of weight- vs thruster-driven estimation results, and its diagnosis."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from daq.run_data import curve_draws
from estimation import estimate
from estimation.crosscheck import cross_check, markdown, write_crosscheck_report
from estimation.thrust_curve import ThrustCurve
from tests.estimation.synth import SURGE_TRUTH, Physics, thruster_run, tow_set

NAMES = ("inertia", "linear_damping", "quadratic_damping")


def _doc(values, stds, *, axis="surge", effects=(), draws=0, rmse=(1e-3, 1e-4)) -> dict:
    return {
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
    assert [f.name for f in files] == ["report.md", "crosscheck.png"]
    assert files[1].stat().st_size > 5000


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
    pendulum = {"analysis": "pendulum", "axis": "surge", "coefficients": {}}
    with pytest.raises(ValueError, match="weight_result: a pendulum free-decay analysis"):
        cross_check(pendulum, w)
