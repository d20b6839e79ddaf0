"""Estimating a pendulum free decay over HTTP and on the estimation page (headless Chromium),
on the simulated rig with a fast pendulum rig file (the scenario's surge coefficients)."""

from __future__ import annotations

import re

import pytest

from tests.api.conftest import (
    AUTH,
    SHORT_TOW,
    how_it_ended,
    signed_in_page,
    start_job,
    wait_job,
)

pytestmark = pytest.mark.rig_service(rig="fast-pendulum")

ALPHA = 143.26 - 30.0  # kg: the scenario's surge inertia minus BENBAM's dry mass


@pytest.fixture(scope="module")
def runs(client) -> dict[str, str]:
    body = {"start_angle_rad": 0.3, "stop_amplitude_rad": 0.01, "max_time_s": 12, "baseline_s": 0.3}
    pendulum = wait_job(client, start_job(client, "/api/jobs/pendulum", body), timeout_s=40)
    assert pendulum["state"] == "completed", how_it_ended(pendulum)
    tow = wait_job(client, start_job(client, "/api/jobs/tow", SHORT_TOW))
    assert tow["state"] == "completed", how_it_ended(tow)
    return {"pendulum": pendulum["run_ids"][0], "tow": tow["run_ids"][0]}


def test_pendulum_estimation_job_stores_the_methods_and_report(client, runs):
    r = client.post("/api/jobs/estimation", json={"run_ids": [runs["pendulum"]]}, headers=AUTH)
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=60)
    assert job["state"] == "completed", how_it_ended(job)
    res = job["outcome"]
    assert res["analysis"] == "pendulum" and res["method"] == "output-error"
    assert res["coefficients"]["added_mass"]["value"] == pytest.approx(ALPHA, rel=0.03)
    # the plant has the scenario's quadratic drag: the search names it
    assert [e["name"] for e in res["effects"]] == ["quadratic_damping"]
    assert {m["method"] for m in res["methods"]} >= {"damped-fit", "log-decrement"}
    stored = client.get(f"/api/results/{job['result_id']}", headers=AUTH).json()
    assert stored["kind"] == "estimation" and stored["data"]["analysis"] == "pendulum"
    assert set(stored["report_plots"]) == {"fit", "peaks", "residual_vs_rate"}
    png = client.get(f"/api/results/{job['result_id']}/report/peaks.png", headers=AUTH)
    assert png.status_code == 200 and png.content.startswith(b"\x89PNG")


def test_methods_are_checked_per_kind_and_kinds_not_mixed(client, runs):
    for body, text in (
        (
            {"run_ids": [runs["pendulum"]], "method": "ls-raw"},
            "method: 'ls-raw' is not allowed for pendulum runs; allowed: output-error, damped-fit",
        ),
        (
            {"run_ids": [runs["tow"]], "method": "log-decrement"},
            "method: 'log-decrement' is not allowed for tow/spin runs",
        ),
        (
            {"run_ids": [runs["pendulum"], runs["tow"]]},
            "run_ids: got mixed kinds ['pendulum', 'tow']",
        ),
    ):
        r = client.post("/api/jobs/estimation", json=body, headers=AUTH)
        assert r.status_code == 422, r.text
        assert text in r.json()["detail"]


def test_estimation_page_shows_a_pendulum_result(chromium, client, service, runs, tmp_path):
    from playwright.sync_api import expect

    with signed_in_page(chromium, service, client) as page:
        page.click("nav a[data-page=estimation]")
        box = page.locator(f"#est-runs input[value='{runs['pendulum']}']")
        expect(box).to_have_attribute("data-kind", "pendulum")
        box.check()
        page.select_option("#est-method", "damped-fit")
        page.click("#est-run")
        expect(page.locator("#est-state")).to_have_text("completed", timeout=60_000)
        methods = page.locator("#est-methods")
        expect(methods).to_contain_text("log-decrement")
        expect(methods).to_contain_text("equation-error")
        # each seed row's coefficients with their own U, k and ν; the seed headline's budget
        expect(methods).to_contain_text(re.compile(r"± \S+ \(U \S+, k \S+, ν \S+\)"))
        # each seed row's largest z from the output-error row of its run, as the report's
        expect(methods.locator("th").last).to_have_text("vs output error")
        expect(methods).to_contain_text(re.compile(r"\d+\.\d σ \([αβγ]\)"))
        expect(page.locator("#est-uncertainty .est-budget-summary")).to_contain_text("added_mass")
        expect(page.locator("#est-coefs")).to_contain_text("added_mass (kg)")
        subject = "surge pendulum free-decay test / damped-fit"  # GET /api/results' words
        expect(page.locator("#est-rmse")).to_contain_text(subject)
        expect(page.locator("#est-rmse")).to_contain_text("rad")
        expect(page.locator("#est-effects-list")).to_contain_text("quadratic_damping")
        # an effect found: each coefficient shows its value before the search beside it
        expect(page.locator("#est-coefs")).to_contain_text("before effects")
        # B_e's amplitudes in rad and in degrees, as the damping ratios above are named
        expect(page.locator("#est-equivalent tbody tr").first).to_contain_text(
            re.compile(r"^\S+ rad \(\S+°\)")
        )
        expect(page.locator("#est-plots img").first).to_be_visible(timeout=20_000)
        methods.screenshot(path=str(tmp_path / "pendulum-methods.png"))
        # The peaks plot on the time from the release, as the report (not the run's clock);
        # drawn once Plotly has loaded (the page loads it with its first plot).
        page.wait_for_function("() => document.getElementById('est-fit-plot').layout")
        layout = page.evaluate("() => document.getElementById('est-fit-plot').layout")
        assert layout["xaxis"]["title"]["text"] == "time from release [s]"
        first_peak = page.evaluate("() => document.getElementById('est-fit-plot').data[0].x[0]")
        assert 0 <= first_peak < 5.0, first_peak
