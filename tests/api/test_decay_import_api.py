"""``POST /api/runs/import?kind=decay&dof=…`` and the estimation job on a free decay: the
kind's own query fields come from the registry (``daq.decay_import.DecayImport``); bad ones are a
one-line 422 naming the field. Data: a heave decay integrated by scipy's ``solve_ivp``
(``tests.integration.test_decay_import.heave_decay``); the rule is issue 20's (added inertia
within 2 %, damping within 10 %)."""

from __future__ import annotations

import re

import pytest

from tests.api.conftest import AUTH, how_it_ended, wait_job
from tests.integration.test_decay_import import heave_decay

CSV = {"Content-Type": "text/csv"}


def test_the_http_import_takes_a_decay_and_the_estimation_job_fits_it(client, tmp_path):
    truth = heave_decay(tmp_path / "heave.csv", 10.0, seed=4)
    body = (tmp_path / "heave.csv").read_bytes()
    query = (f"kind=decay&dof=heave&stiffness={truth['stiffness']:g}&known_inertia=10"
             "&release_time_s=1&filename=heave.csv")  # fmt: skip
    r = client.post(f"/api/runs/import?{query}", content=body, headers=AUTH | CSV)
    assert r.status_code == 201, r.text
    run_id = r.json()["run_id"]
    run = client.get(f"/api/runs/{run_id}", headers=AUTH).json()
    assert run["kind"] == "decay" and run["channel_names"] == ["decay_position"]
    assert run["parameters"]["stiffness"] == pytest.approx(truth["stiffness"])

    wrong = {"run_ids": [run_id], "method": "ls-raw"}
    r = client.post("/api/jobs/estimation", json=wrong, headers=AUTH)
    assert r.status_code == 422
    assert "method: 'ls-raw' is not allowed for decay runs; allowed: output-error" in r.text

    body_json = {"run_ids": [run_id], "search_effects": False}
    r = client.post("/api/jobs/estimation", json=body_json, headers=AUTH)
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=60)
    assert job["state"] == "completed", how_it_ended(job)
    c = job["outcome"]["coefficients"]
    assert c["inertia"]["value"] == pytest.approx(truth["added"], rel=0.02)
    assert c["linear_damping"]["value"] == pytest.approx(truth["damping"], rel=0.10)
    budget = job["outcome"]["budget"]["coefficients"]
    assert set(budget) == set(c)  # every coefficient of a decay carries U (issue 31)
    inertia = budget["inertia"]
    assert abs(inertia["value"] - truth["added"]) <= inertia["expanded_uncertainty"]
    assert not job["outcome"]["budget"]["type_b_declared"]


def test_a_declared_stiffness_tolerance_is_a_type_b_row_of_a_decays_budget(client, tmp_path):
    """A free decay scales every coefficient alike: the stiffness known to ±2 % (u = 2 %/√3)
    puts ≈ 1.15 % of the whole inertia M into the added inertia's u_c (∂A/∂k = M/k)."""
    truth = heave_decay(tmp_path / "heave.csv", 10.0, seed=4)
    k = truth["stiffness"]
    query = (f"kind=decay&dof=heave&stiffness={k:g}&known_inertia=10&release_time_s=1"
             f"&stiffness_tolerance={0.02 * k:g}&filename=heave.csv")  # fmt: skip
    r = client.post(
        f"/api/runs/import?{query}",
        content=(tmp_path / "heave.csv").read_bytes(),
        headers=AUTH | CSV,
    )
    assert r.status_code == 201, r.text
    body_json = {"run_ids": [r.json()["run_id"]], "search_effects": False}
    r = client.post("/api/jobs/estimation", json=body_json, headers=AUTH)
    job = wait_job(client, r.json()["id"], timeout_s=60)
    assert job["state"] == "completed", how_it_ended(job)
    budget = job["outcome"]["budget"]
    assert budget["type_b_declared"]
    rows = {row["type"]: row for row in budget["coefficients"]["inertia"]["rows"]}
    total = 10.0 + budget["coefficients"]["inertia"]["value"]
    assert rows["B"]["contribution"] == pytest.approx(total * 0.02 / 3**0.5, rel=0.05)
    assert budget["coefficients"]["inertia"]["dominant_source"].startswith("stiffness")


@pytest.mark.parametrize(
    ("query", "detail"),
    [
        ("kind=decay", "dof: missing is not allowed (a free decay names its dof"),
        ("kind=decay&dof=heave&force_n=3", "force_n: not used by a free decay (it has no drive)"),
        ("kind=decay&dof=wobble", "dof: 'wobble' is not allowed (Input should be"),
        ("kind=tow&force_n=3&stiffness=2", "stiffness: '2' is not allowed (not used by a tow)"),
        ("kind=spin&torque_nm=3&dof=heave", "dof: 'heave' is not allowed (not used by a spin)"),
        ("kind=decay&dof=heave&stiffness_tolerance=-1", "stiffness_tolerance: '-1' is not allowed"),
    ],
)
def test_the_http_import_names_a_bad_decay_field(client, query, detail):
    body = b"t,position\n0,0.1\n0.1,0.09\n0.2,0.05\n"
    r = client.post(f"/api/runs/import?{query}", content=body, headers=AUTH | CSV)
    assert r.status_code == 422, r.text
    assert r.json()["detail"].startswith(detail), r.json()


def test_the_estimation_page_lists_and_fits_a_decay(chromium, service, client, tmp_path):
    """The Estimation page offers every kind with an estimator (GET /api/kinds), a decay
    among them, sends its "leave out flagged repeats" box as ``exclude_outliers``, and shows
    its coefficients with the units and labels the result carries."""
    from playwright.sync_api import expect

    from tests.api.conftest import estimate_in_page, signed_in_page

    truth = heave_decay(tmp_path / "heave.csv", 10.0, seed=5)
    query = f"kind=decay&dof=heave&stiffness={truth['stiffness']:g}&known_inertia=10"
    r = client.post(f"/api/runs/import?{query}&release_time_s=1",
                    content=(tmp_path / "heave.csv").read_bytes(), headers=AUTH | CSV)  # fmt: skip
    assert r.status_code == 201, r.text
    with signed_in_page(chromium, service, client) as page:
        errors: list[str] = []
        page.on("pageerror", lambda err: errors.append(str(err)))
        page.click("nav a[data-page=estimation]")
        page.uncheck("#est-effects")  # the base model: the truth has no other term
        page.check("#est-exclude")  # the request's exclude_outliers, every kind's
        with page.expect_request(
            lambda req: req.method == "POST" and req.url.endswith("/api/jobs/estimation")
        ) as request:
            estimate_in_page(page, [r.json()["run_id"]], timeout_ms=60_000)
        assert request.value.post_data_json["exclude_outliers"] is True
        # the identified inertia is the added one, named so beside the body's own given
        expect(page.locator("#est-coefs")).to_contain_text("added mass (body's own 10 given) (kg)")
        # the result's facts (the subject, the error before and after), then its budget, as
        # report.md and rig estimate order them
        expect(page.locator("#est-rmse + #est-uncertainty")).to_have_count(1)
        budget_row = page.locator("#est-uncertainty .est-budget-summary tr[data-quantity=inertia]")
        expect(budget_row.locator("td").first).to_have_text("added mass (body's own 10 given)")
        expect(page.locator("#est-uncertainty .est-budget-head").first).to_contain_text(
            "added mass (body's own 10 given) = "
        )
        expect(page.locator("#est-rmse")).to_contain_text("heave free decay")
        rmse = page.locator("#est-rmse tr", has_text="RMSE after").locator("td").nth(1)
        expect(rmse).to_have_text(re.compile(r"^\S+ m$"))  # a heave's position: m
        # the equivalent linear damping over the swings: five amplitudes in m, B_e in N·s/m
        expect(page.locator("#est-equivalent")).to_be_visible()
        rows = page.locator("#est-equivalent tbody tr")
        expect(rows).to_have_count(5)
        expect(rows.first).to_contain_text(" m")
        expect(rows.first).to_contain_text("N·s/m")
        assert errors == []
