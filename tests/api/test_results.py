"""Estimation and calibration through the API: jobs, stored results, report plots."""

from __future__ import annotations

import json
import tempfile

import pytest

from tests.api.conftest import AUTH, how_it_ended, start_job, wait_job

#: The rig behind the service runs in process on simulated time (tests/api/conftest.py).
pytestmark = pytest.mark.simtime


@pytest.fixture(scope="module")
def two_tows(client) -> list[str]:
    runs = []
    for force in (24.5, 83.3):
        job_id = start_job(
            client, "/api/jobs/tow", {"force_n": force, "max_time_s": 1.5, "baseline_s": 0.3}
        )
        job = wait_job(client, job_id)
        assert job["state"] == "completed", how_it_ended(job)
        runs += job["run_ids"]
    return runs


def test_estimation_job_returns_the_result_json_and_report_plots(client, two_tows):
    r = client.post(
        "/api/jobs/estimation",
        json={"run_ids": [run[:8] for run in two_tows], "method": "output-error"},
        headers=AUTH,
    )
    assert r.status_code == 202, r.text
    assert r.json()["run_ids"] == two_tows  # prefixes resolved to full ids at once
    job = wait_job(client, r.json()["id"], timeout_s=60)
    assert job["state"] == "completed", how_it_ended(job)
    result = job["outcome"]
    assert result["axis"] == "surge"
    assert result["method"] == "output-error"
    assert set(result["coefficients"]) == {"inertia", "linear_damping", "quadratic_damping"}
    for c in result["coefficients"].values():
        assert c["value"] > 0 and c["std"] >= 0
    assert result["rmse_after"] <= result["rmse_before"] + 1e-12
    stored = client.get(f"/api/results/{job['result_id']}", headers=AUTH).json()
    assert stored["kind"] == "estimation"
    assert sorted(stored["run_ids"]) == sorted(two_tows)
    assert stored["report_plots"] == ["fit", "force_residual"]
    png = client.get(f"/api/results/{job['result_id']}/report/fit.png", headers=AUTH)
    assert png.status_code == 200
    assert png.content.startswith(b"\x89PNG")
    svg = client.get(f"/api/results/{job['result_id']}/report/fit.svg", headers=AUTH)
    assert svg.status_code == 200 and svg.headers["content-type"].startswith("image/svg+xml")
    assert "position [m]" in svg.text and "time from release [s]" in svg.text
    other = client.get(f"/api/results/{job['result_id']}/report/report.md.svg", headers=AUTH)
    assert other.status_code == 404
    bad = client.get(f"/api/results/{job['result_id']}/report/..%2Fsecret.png", headers=AUTH)
    assert bad.status_code == 404
    listed = client.get(f"/api/runs/{two_tows[0]}/results", headers=AUTH).json()
    assert job["result_id"] in [r["id"] for r in listed]
    answers = client.get(f"/api/jobs/{job['id']}", headers=AUTH).text + json.dumps(stored)
    assert "report_files" not in answers and tempfile.gettempdir() not in answers  # no paths


def test_estimation_input_errors(client, two_tows):
    r = client.post(
        "/api/jobs/estimation", json={"run_ids": two_tows, "method": "magic"}, headers=AUTH
    )
    assert r.status_code == 422
    assert r.json()["errors"][0]["field"] == "method"
    r = client.post("/api/jobs/estimation", json={"run_ids": []}, headers=AUTH)
    assert r.status_code == 422
    assert r.json()["errors"][0]["field"] == "run_ids"


def test_thrust_calibration_job_stores_the_curve(client):
    body = {"commands": [0.3, 0.6, 0.8], "settle_s": 0.1, "samples_per_step": 2, "tare_samples": 3}
    job = wait_job(client, start_job(client, "/api/jobs/calibration", body), timeout_s=60)
    assert job["state"] == "completed", how_it_ended(job)
    calibration = job["outcome"]["calibration"]
    latest = client.get("/api/calibration/latest", headers=AUTH).json()
    assert latest["id"] == calibration["result_id"]
    assert latest["run_ids"] == job["run_ids"]
    fit = latest["data"]["fit"]
    assert fit["parameters"]["forward_gain"]["value"] > 0
    assert fit["command_range"] == [-0.8, 0.8]
    commands = [row["command"] for row in latest["data"]["table"]]
    assert max(commands) == 0.8 and min(commands) == -0.8
    # Each step carries the controller's telemetry, as a thrust stand logs it: RPM and
    # current per thruster, power V·I and efficiency |F|/P; current rises with thrust.
    steps = [r for r in latest["data"]["table"] if abs(r["command"]) == 0.8]
    for row in steps:
        assert len(row["rpm_per_thruster"]) == len(row["current_per_thruster_a"]) == 2
        assert row["power_w"] == pytest.approx(row["supply_voltage_v"] * row["current_a"])
        assert row["efficiency_n_per_w"] == pytest.approx(
            abs(row["thrust_per_thruster_n"]) / row["power_w"]
        )
        assert abs(row["rpm"]) > 1000 and row["current_a"] > 1.0
    low = [r["current_a"] for r in latest["data"]["table"] if abs(r["command"]) == 0.3]
    assert max(low) < min(r["current_a"] for r in steps)
    assert latest["channels"] == ["current_a", "rpm", "power_w", "efficiency_n_per_w"]


def test_spin_job_by_weight(client):
    body = {"weight_kg": 1.0, "max_time_s": 1.0, "baseline_s": 0.2}
    job = wait_job(client, start_job(client, "/api/jobs/spin", body))
    assert job["state"] == "completed", how_it_ended(job)
    run = client.get(f"/api/runs/{job['run_ids'][0]}", headers=AUTH).json()
    assert run["kind"] == "spin"
    assert run["parameters"]["torque_nm"] == pytest.approx(1.0 * 9.8 * 0.0926)
