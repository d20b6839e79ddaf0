"""The pendulum free-decay job over HTTP and from the rig page in headless Chromium, on the
simulated rig with a fast pendulum rig file."""

from __future__ import annotations

import pytest

from tests.api.conftest import AUTH, how_it_ended, signed_in_page, start_job, wait_job

pytestmark = pytest.mark.rig_service(rig="fast-pendulum")


def test_bad_pendulum_requests_are_422_naming_the_field(client):
    for body, field, text in (
        ({"start_angle_rad": 0.9}, "start_angle_rad", "max_angle_rad"),
        ({}, "start_angle_rad", "allowed 0 < start_angle_rad ≤ 0.5 rad"),
        ({"start_angle_rad": 0.3, "stop_amplitude_rad": -1.0}, "stop_amplitude_rad", "allowed"),
    ):
        r = client.post("/api/jobs/pendulum", json=body, headers=AUTH)
        assert r.status_code == 422, r.text
        (problem,) = r.json()["errors"]
        assert problem["field"] == field and text in problem["allowed"]
    strict = client.post("/api/jobs/pendulum", json={"start_angle_rad": "0.3"}, headers=AUTH)
    assert strict.status_code == 422  # a number must be a JSON number


def test_pendulum_job_end_to_end_stores_a_completed_decay(client):
    body = {"start_angle_rad": 0.3, "stop_amplitude_rad": 0.12, "max_time_s": 15, "baseline_s": 0.3}
    job = wait_job(client, start_job(client, "/api/jobs/pendulum", body), timeout_s=40)
    assert job["state"] == "completed", how_it_ended(job)
    assert job["kind"] == "pendulum" and job["label"] == "pendulum 0.3 rad"
    (run_id,) = job["run_ids"]
    run = client.get(f"/api/runs/{run_id}", headers=AUTH).json()
    assert run["kind"] == "pendulum" and run["status"] == "completed"
    assert run["parameters"]["stop_amplitude_rad"] == 0.12
    samples = client.get(f"/api/runs/{run_id}/samples", headers=AUTH).json()
    angle = [a for a in samples["channels"]["pendulum_angle"] if a is not None]
    assert max(angle) == pytest.approx(0.3, abs=1e-3) and min(angle) < -0.1  # it swung
    status = client.get("/api/rig", headers=AUTH).json()
    assert status["sample"]["channels"]["pendulum_release"] == 0.0  # caught
    assert status["lock_holder"] is None


def test_pendulum_tab_starts_a_decay_from_the_rig_page(chromium, client, service):
    from playwright.sync_api import expect

    with signed_in_page(chromium, service, client) as page:
        page.click(".tabs button[data-form=pendulum]")
        form = "#form-pendulum"
        expect(page.locator(form)).to_be_visible()
        expect(page.locator("#form-tow")).to_be_hidden()
        page.fill(f"{form} [name=start_angle_rad]", "0.9")  # beyond max_angle_rad
        page.click(f"{form} button[type=submit]")
        expect(page.locator(f"{form} .errors")).to_contain_text("start_angle_rad")
        page.fill(f"{form} [name=start_angle_rad]", "0.3")
        page.fill(f"{form} [name=stop_amplitude_rad]", "0.12")
        page.fill(f"{form} [name=max_time_s]", "15")
        page.fill(f"{form} [name=baseline_s]", "0.3")
        page.click(f"{form} button[type=submit]")
        expect(page.locator("#job-state")).to_have_text("completed", timeout=40_000)
        page.click("nav a[data-page=runs]")
        row = page.locator("#runs-table tbody tr").first
        expect(row).to_contain_text("pendulum")
        expect(row).to_contain_text("0.3 rad")
