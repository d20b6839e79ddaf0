"""Analysis API: AHP weights and the sensitivity analysis of a fixture vehicle, with a
stored estimation (from a real tow on the simulated rig) plugged in."""

from __future__ import annotations

import pytest

from api.core.estimation_job import run_estimation
from tests.api.conftest import AUTH

#: The rig behind the service runs in process on simulated time (tests/api/conftest.py).
pytestmark = pytest.mark.simtime

C1 = {"name": "C1", "matrix": [[1, 3], [1 / 3, 1]]}
C2 = {"name": "C2", "matrix": [[1, 1 / 3, 1], [3, 1, 3], [1, 1 / 3, 1]], "labels": ["p", "T", "d"]}
C3 = {"name": "C3", "matrix": [[1, 1], [1, 1]], "labels": ["Ds", "DT"]}
INCONSISTENT = [[1, 5, 1 / 7, 3], [1 / 5, 1, 7, 1 / 3], [7, 1 / 7, 1, 5], [1 / 3, 3, 1 / 5, 1]]
RESPONSES = ["steady_surge_speed", "surge_rise_time_90", "steady_yaw_rate"]


def test_ahp_hierarchy_gives_the_seed_weights(client):
    r = client.post("/api/analysis/ahp", json={"criteria": C1, "groups": [C2, C3]}, headers=AUTH)
    assert r.status_code == 200, r.text
    out = r.json()
    expected = {"Ds": 0.125, "DT": 0.125, "p": 0.15, "d": 0.15, "T": 0.45}
    assert out["weights"] == pytest.approx(expected)
    assert out["cr"] == pytest.approx(0.0, abs=1e-9)
    assert [g["lambda_max"] for g in out["groups"]] == pytest.approx([3.0, 2.0])


def test_ahp_single_matrix_and_its_errors(client):
    r = client.post("/api/analysis/ahp", json=C2, headers=AUTH)
    assert r.status_code == 200, r.text
    assert r.json()["weights_by_label"] == pytest.approx({"p": 0.2, "T": 0.6, "d": 0.2})
    bad = client.post(
        "/api/analysis/ahp", json={"name": "mine", "matrix": INCONSISTENT}, headers=AUTH
    )
    assert bad.status_code == 422
    assert bad.json()["detail"].startswith("mine: consistency ratio CR =")
    unrecip = client.post("/api/analysis/ahp", json={"matrix": [[1, 3], [0.5, 1]]}, headers=AUTH)
    assert unrecip.status_code == 422
    assert "matrix[1][0]: 0.5" in unrecip.json()["detail"]
    negative = client.post("/api/analysis/ahp", json={"matrix": [[1, -3], [1, 1]]}, headers=AUTH)
    assert negative.status_code == 422 and "matrix.0.1" in negative.json()["detail"]
    assert client.post("/api/analysis/ahp", json=C2).status_code == 401


def test_sensitivity_of_a_fixture_vehicle(client):
    body = {
        "vehicle": "benbam",
        "responses": RESPONSES,
        "thresholds": [0.05],
        "keep": ["linear_damping.sway"],
        "ahp": {"matrix": [[1, 1, 3], [1, 1, 3], [1 / 3, 1 / 3, 1]], "labels": RESPONSES},
    }
    r = client.post("/api/analysis/sensitivity", json=body, headers=AUTH)
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["weights"] == pytest.approx(
        {RESPONSES[0]: 3 / 7, RESPONSES[1]: 3 / 7, RESPONSES[2]: 1 / 7}
    )
    assert out["ahp"]["cr"] == pytest.approx(0.0, abs=1e-9)
    composites = [row["composite"] for row in out["ranking"]]
    assert composites == sorted(composites, reverse=True)
    assert out["ranking"][0]["name"] in ("quadratic_damping.surge", "quadratic_damping.yaw")
    assert {(s["criterion"], s["threshold"]) for s in out["sweep"]} == {
        (c, t) for c in ("composite", "max") for t in (0.005, 0.0075, 0.01, 0.05)
    }
    for s in out["sweep"]:
        assert "linear_damping.sway" not in s["removed"]
        assert set(s["errors"]) == set(RESPONSES)
    assert out["identifiability"]["next_test"]["coefficient"] is None  # no σ anywhere yet


def test_sensitivity_with_a_stored_estimate(client, tow_job):
    store = client.app.state.service.store
    data = run_estimation(store, tow_job["run_ids"], search_effects=False)
    body = {"vehicle": "benbam", "responses": RESPONSES, "estimates": [data["result_id"]]}
    r = client.post("/api/analysis/sensitivity", json=body, headers=AUTH)
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["estimates"][0]["axis"] == "surge"
    assert len(out["run_speeds"]["surge"]) == len(tow_job["run_ids"])
    assert all(s > 0 for s in out["run_speeds"]["surge"])
    row = next(x for x in out["ranking"] if x["name"] == "quadratic_damping.surge")
    assert row["value"] == pytest.approx(data["coefficients"]["quadratic_damping"]["value"])
    assert row["sigma"] == pytest.approx(data["coefficients"]["quadratic_damping"]["std"])
    ident = out["identifiability"]
    assert {c["name"] for c in ident["coefficients"]} == {
        "added_mass.surge",
        "linear_damping.surge",
        "quadratic_damping.surge",
    }
    assert ident["next_test"]["coefficient"] in {c["name"] for c in ident["coefficients"]}
    assert ident["next_test"]["reason"]


@pytest.mark.parametrize(
    ("change", "status", "text"),
    [
        ({"vehicle": "nope"}, 404, "no vehicle named 'nope'"),
        ({"estimates": [987654]}, 404, "987654"),
        ({"responses": ["speed"]}, 422, "responses: 'speed' is not allowed"),
        ({"keep": ["drag.surge"]}, 422, "keep: 'drag.surge' is not allowed"),
        ({"delta": 0.7}, 422, "delta"),
        ({"weights": {"steady_surge_speed": 1}, "ahp": C1}, 422, "either weights or ahp"),
        ({"responses": ["steady_heave_speed"]}, 422, "no thrust along heave"),
    ],
)
def test_sensitivity_errors_name_the_field(client, change, status, text):
    body = {"vehicle": "benbam", "responses": RESPONSES} | change
    r = client.post("/api/analysis/sensitivity", json=body, headers=AUTH)
    assert r.status_code == status, r.text
    assert text in r.json()["detail"]


def test_response_library_is_listed(client):
    r = client.get("/api/analysis/responses", headers=AUTH)
    assert r.status_code == 200
    names = {x["name"]: x for x in r.json()}
    assert names["steady_surge_speed"]["unit"] == "m/s"
    assert names["turning_diameter"]["manoeuvre"] == "turn"


def test_sensitivity_of_the_seed002_rov_with_failing_knock_outs(client):
    r = client.post("/api/analysis/sensitivity", json={"vehicle": "seed002-rov"}, headers=AUTH)
    assert r.status_code == 200, r.text
    out = r.json()
    assert "steady_heave_speed" in out["weights"]  # 8 thrusters: heave thrust too
    assert out["ranking"][0]["composite"] is None  # a knock-out the model cannot survive
    assert any("simulation failed" in n for n in out["notes"])
    assert "∞" in out["identifiability"]["next_test"]["unmeasured"]
