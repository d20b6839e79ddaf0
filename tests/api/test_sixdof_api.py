"""6-DOF routes: vehicle list and detail, simulation with commands, force and stored
estimates, errors named by field."""

from __future__ import annotations

import math

import pytest

from api.core.vehicle_files import FIXTURE_VEHICLES
from tests.api.conftest import AUTH

#: The rig behind the service runs in process on simulated time (tests/api/conftest.py).
pytestmark = pytest.mark.simtime
FIXTURES = FIXTURE_VEHICLES.parents[1]  # the checkout or the installed package


def test_vehicle_list_and_detail(client):
    r = client.get("/api/vehicles", headers=AUTH)
    assert r.status_code == 200, r.text
    names = {v["name"]: v for v in r.json()}
    assert {"seed002-rov", "benbam"} <= set(names)
    assert names["seed002-rov"]["thrusters"] == [str(i) for i in range(1, 9)]
    detail = client.get("/api/vehicles/seed002-rov", headers=AUTH).json()
    b = detail["allocation_matrix"]
    assert len(b) == 6 and len(b[0]) == 8
    # thruster 1: 2.4336·cos 35° forward; yaw moment of the lower thrusters only
    assert b[0][0] == pytest.approx(2.4336 * math.cos(math.radians(35)), rel=1e-9)
    assert b[5][4:] == pytest.approx([0, 0, 0, 0], abs=1e-12)
    assert detail["vehicle"]["coefficients"]["added_mass.heave"] == pytest.approx(219.5567)
    assert detail["vehicle"]["total_inertia"]["roll"] == pytest.approx(17.8011)
    assert client.get("/api/vehicles/nope", headers=AUTH).status_code == 404
    assert client.get("/api/vehicles", headers={}).status_code == 401


def test_simulate_with_commands_reaches_the_steady_speed(client):
    body = {"vehicle": "benbam", "commands": [0.3, 0.3], "duration_s": 30, "dt": 0.01}
    r = client.post("/api/sixdof/simulate", json=body, headers=AUTH)
    assert r.status_code == 200, r.text
    out = r.json()
    kl, kq, force = 20.16, 241.14, 24.0
    expected = (-kl + math.sqrt(kl**2 + 4 * kq * force)) / (2 * kq)
    assert out["steady"]["nu"]["u"] == pytest.approx(expected, rel=1e-4)
    assert out["steady"]["settled"] is True
    assert out["tau"]["X"] == pytest.approx(force)
    traj = out["trajectory"]
    assert 1000 < len(traj["t"]) <= 2000  # 3001 samples decimated
    assert traj["t"][-1] == pytest.approx(30.0)
    assert traj["nu"]["u"][-1] == out["steady"]["nu"]["u"]


def test_simulate_plugs_in_a_stored_estimate(client, tow_job):
    store = client.app.state.service.store
    doc = {
        "axis": "surge",
        "coefficients": {
            "inertia": {"value": 100.0, "std": 2.0},
            "linear_damping": {"value": 30.0, "std": 1.0},
            "quadratic_damping": {"value": 100.0, "std": 5.0},
        },
    }
    result_id = store.add_result(tow_job["run_ids"], "estimation", doc)
    body = {"vehicle": "benbam", "force": [24, 0, 0, 0, 0, 0], "duration_s": 40}
    r = client.post("/api/sixdof/simulate", json=body | {"estimates": [result_id]}, headers=AUTH)
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["applied_estimates"][0]["added_mass"] == pytest.approx(70.0)
    assert out["coefficients"]["linear_damping.surge"] == 30.0
    expected = (-30 + math.sqrt(30**2 + 4 * 100 * 24)) / (2 * 100)
    assert out["steady"]["nu"]["u"] == pytest.approx(expected, rel=1e-4)
    missing = client.post("/api/sixdof/simulate", json=body | {"estimates": [999999]}, headers=AUTH)
    assert missing.status_code == 404
    calibration = store.add_result(tow_job["run_ids"], "calibration", {"thrusters": []})
    other = client.post(
        "/api/sixdof/simulate", json=body | {"estimates": [calibration]}, headers=AUTH
    )
    assert other.status_code == 422
    assert f"estimates: result {calibration} is a 'calibration' result" in other.text


@pytest.mark.parametrize(
    ("change", "field_text"),
    [
        ({"commands": [0.3, 1.3]}, "thruster 'starboard'"),
        ({"commands": [0.3, 0.3, 0.3]}, "one per thruster"),
        ({"duration_s": 601}, "duration_s"),
        ({"duration_s": 0}, "duration_s"),
        ({"force": [1, 2, 3]}, "force"),
        ({"dt": 0.001, "duration_s": 600}, "dt"),
        ({"commands": None}, "commands"),
    ],
)
def test_simulate_errors_name_the_field(client, change, field_text):
    body = {"vehicle": "benbam", "commands": [0.3, 0.3], "duration_s": 10} | change
    r = client.post("/api/sixdof/simulate", json=body, headers=AUTH)
    assert r.status_code == 422, r.text
    assert field_text in r.json()["detail"]


def test_simulate_needs_the_write_token(client):
    body = {"vehicle": "benbam", "commands": [0.3, 0.3], "duration_s": 10}
    assert client.post("/api/sixdof/simulate", json=body).status_code == 401
    r = client.post("/api/sixdof/simulate", json=body | {"vehicle": "../etc/x"}, headers=AUTH)
    assert r.status_code == 404


def test_cli_prints_steady_values_and_json():
    import json

    from click.testing import CliRunner

    from api.cli.main import main

    runner = CliRunner()
    text = runner.invoke(main, ["sixdof", "benbam", "--commands", "0.3,0.3", "--duration", "30"])
    assert text.exit_code == 0, text.output
    assert "u =  0.2764" in text.output and "settled: yes" in text.output
    out = runner.invoke(
        main, ["sixdof", "seed002-rov", "--force", "0,0,0,0,0,0.5", "--duration", "60", "--json"]
    )
    assert out.exit_code == 0, out.output
    doc = json.loads(out.output)
    kl, kq = 1.6711, 1.2674
    assert doc["steady"]["nu"]["r"] == pytest.approx(
        (-kl + math.sqrt(kl**2 + 4 * kq * 0.5)) / (2 * kq), rel=1e-4
    )
    assert len(doc["trajectory"]["t"]) <= 2000
    bad = runner.invoke(main, ["sixdof", "benbam", "--commands", "0.3,0.9,0.1"])
    assert bad.exit_code == 2
    assert "one per thruster (2" in bad.output


def test_vehicle_answers_hold_no_path_of_this_machine(client, tmp_path, monkeypatch):
    lab = tmp_path / "lab-vehicles"
    lab.mkdir()
    (lab / "broken.toml").write_text("[vehicle\n")
    monkeypatch.setenv("RIG_VEHICLES_DIR", str(lab))
    listed = client.get("/api/vehicles", headers=AUTH)
    detail = client.get("/api/vehicles/seed002-rov", headers=AUTH)
    for text in (listed.text, detail.text):
        assert str(FIXTURES) not in text and str(tmp_path) not in text, text
    files = {v["name"]: v for v in listed.json()}
    assert files["seed002-rov"]["file"] == "fixtures/vehicles/seed002-rov.toml"
    assert files["broken"]["file"] == "$RIG_VEHICLES_DIR/broken.toml"
    assert files["broken"]["error"].startswith("$RIG_VEHICLES_DIR/broken.toml: file:")
    assert detail.json()["file"] == "fixtures/vehicles/seed002-rov.toml"
